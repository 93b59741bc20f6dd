//! The four-point examples of the Beta-spline paper (Yang et al. 2021, Examples 1 and 2), shared
//! by the unit tests of the curve, the interpolation and the documents.

use crate::sphere::geometry::point::PointSet;

/// `v` scaled to unit length (the paper prints its points to 4 decimals).
fn unit(v: [f64; 3]) -> Vec<f64> {
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    v.iter().map(|x| x / n).collect()
}

/// The paper's Example 1.
pub(crate) fn example1() -> PointSet {
    PointSet::try_from_rows(&[
        unit([0.6296, -0.1171, -0.7680]),
        unit([-0.8142, -0.2856, 0.5055]),
        unit([-0.4037, 0.6855, 0.6059]),
        unit([-0.7206, -0.5462, -0.4270]),
    ])
    .unwrap()
}

/// The paper's Example 2, with its rounded 0.7071 kept on purpose (re-normalised).
#[allow(clippy::approx_constant)]
pub(crate) fn example2() -> PointSet {
    PointSet::try_from_rows(&[
        unit([1.0, 0.0, 0.0]),
        unit([0.6852, -0.5424, 0.4861]),
        unit([0.7071, 0.0, 0.7071]),
        unit([0.0, 1.0, 0.0]),
    ])
    .unwrap()
}
