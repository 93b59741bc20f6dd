//! Geometry of S^n: unit vectors, geodesic angles, SLERP and the log/exp maps every curve and
//! fitter builds on.

pub mod arc;
pub mod crossing;
pub mod densify;
pub mod point;
