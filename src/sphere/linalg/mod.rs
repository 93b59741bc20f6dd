//! Small linear algebra the fitters need: symmetric band matrices and their Cholesky factor,
//! general band matrices and their pivoted LU factor.

pub(crate) mod band_lu;
pub(crate) mod banded;
