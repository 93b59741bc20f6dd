//! Max, mean and RMS geodesic error of a curve at the data parameters (GLS-PIA eqs. 35–36).
//!
//! The error of point j is the angle between q_j and C(t_j) in radians: the *parametric*
//! error. The distance from q_j to the nearest point of the curve is never larger.

use crate::sphere::curve::bspline::SphericalBSpline;
use crate::sphere::fit::pass::{run_pass, PassMode};
use crate::sphere::geometry::point::PointSet;
use serde::{Deserialize, Serialize};

/// Summary of geodesic errors, in radians.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ErrorMetrics {
    /// Largest error.
    pub max_error_rad: f64,
    /// Mean error.
    pub mean_error_rad: f64,
    /// Root mean square error (the square root of the geodesic least-squares loss / n).
    pub rms_error_rad: f64,
    /// Index of the data point with the largest error.
    pub max_error_index: usize,
}

/// Running sums from which [`ErrorMetrics`] are made; merged across parallel chunks.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct ErrorSums {
    pub max: f64,
    pub max_index: usize,
    pub sum: f64,
    pub sum_sq: f64,
    pub count: usize,
}

impl ErrorSums {
    #[inline(always)]
    pub fn add(&mut self, index: usize, e: f64) {
        if e > self.max {
            self.max = e;
            self.max_index = index;
        }
        self.sum += e;
        self.sum_sq += e * e;
        self.count += 1;
    }

    pub fn merge(&mut self, o: &ErrorSums) {
        if o.max > self.max {
            self.max = o.max;
            self.max_index = o.max_index;
        }
        self.sum += o.sum;
        self.sum_sq += o.sum_sq;
        self.count += o.count;
    }

    pub fn metrics(&self) -> ErrorMetrics {
        let n = self.count.max(1) as f64;
        ErrorMetrics {
            max_error_rad: self.max,
            mean_error_rad: self.sum / n,
            rms_error_rad: (self.sum_sq / n).sqrt(),
            max_error_index: self.max_index,
        }
    }
}

/// Errors of `spline` at `(points[j], params[j])`.
///
/// # Panics
/// If `points` and `params` differ in length or dimension from the spline (a programming error).
pub fn measure(spline: &SphericalBSpline, points: &PointSet, params: &[f64]) -> ErrorMetrics {
    assert_eq!(points.len(), params.len(), "one parameter per point");
    assert_eq!(
        points.dim(),
        spline.dim(),
        "points and spline share a dimension"
    );
    run_pass(spline, points, params, PassMode::Measure)
        .errors
        .metrics()
}

/// The error of every point, in radians.
pub fn pointwise_errors(spline: &SphericalBSpline, points: &PointSet, params: &[f64]) -> Vec<f64> {
    let curve = spline.evaluate_many(params);
    points
        .iter()
        .zip(curve.iter())
        .map(|(q, c)| crate::sphere::geometry::point::angle_between(q, c))
        .collect()
}
