//! Compression: the fewest stored numbers that keep every point within a tolerance
//! ([`tolerance`]), spherical Douglas–Peucker as the baseline ([`simplify`]), the optimal subset
//! polyline as the lower bound for subset polylines ([`optimal`]), and the byte cost of a stored
//! curve under one coding for every method ([`coding`]).

pub mod coding;
pub mod optimal;
pub mod simplify;
pub mod tolerance;
