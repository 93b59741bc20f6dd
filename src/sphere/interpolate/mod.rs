//! Interpolation: curves through every point, with the cubic spherical Beta-spline ([`beta`]).

pub mod beta;

#[cfg(test)]
pub(crate) mod paper_examples;
