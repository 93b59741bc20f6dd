//! Small linear algebra the fitters need: symmetric band matrices and their Cholesky factor.

pub mod banded;
