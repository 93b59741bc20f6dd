//! Compression: the fewest stored numbers that keep every point within a tolerance
//! ([`tolerance`]), and spherical Douglas–Peucker as the baseline ([`simplify`]).

pub mod simplify;
pub mod tolerance;
