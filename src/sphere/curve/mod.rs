//! What every curve on S^n offers to output code: its domain, and points at parameters.
//! Implemented by the B-spline and the Beta-spline, so sampling, GeoJSON output and the
//! `evaluate` commands serve both.

pub mod beta;
pub mod bezier;
pub mod bspline;

use crate::sphere::geometry::point::PointSet;
use beta::SphericalBetaSpline;
use bspline::SphericalBSpline;

/// A parametric curve on S^n.
pub trait SphericalCurve: Send + Sync {
    /// Number of coordinates per point.
    fn dim(&self) -> usize;

    /// The parameter interval `[start, end]`; evaluation outside it clamps.
    fn domain(&self) -> (f64, f64);

    /// The curve at every parameter of `ts` (unit vectors).
    fn evaluate_many(&self, ts: &[f64]) -> PointSet;

    /// [`evaluate_many`](Self::evaluate_many) into `out` (`ts.len() * dim` coordinates): the
    /// certification loops evaluate a few parameters at a time, thousands of times per curve,
    /// where a fresh point set each time is a measured share of the cost.
    fn evaluate_into(&self, ts: &[f64], out: &mut [f64]) {
        out.copy_from_slice(self.evaluate_many(ts).as_flat());
    }

    /// An upper bound of the speed |dC/dt| (radians per unit of parameter) over `[t0, t1]`
    /// (inside the domain, `t0 <= t1`), proven from the curve's construction (see
    /// [`crate::sphere::certify::bounds`]); infinity when no finite bound is known for so wide an interval
    /// (callers subdivide). Certified distances and dense sampling rest on it.
    fn speed_bound(&self, t0: f64, t1: f64) -> f64;

    /// An upper bound of the ambient acceleration |C''(t)| over `[t0, t1]`, proven like
    /// [`speed_bound`](Self::speed_bound); infinity (the default) when none is known, e.g.
    /// across a joint where the curve is not twice differentiable. Dense sampling certifies a
    /// chord by it in one step where the speed bound needs many sub-intervals.
    fn acceleration_bound(&self, _t0: f64, _t1: f64) -> f64 {
        f64::INFINITY
    }

    /// Parameters strictly inside the domain where the curve may fail to be smooth (distinct
    /// interior knots, segment joints), ascending. Speed bounds are tightest between them.
    fn breaks(&self) -> Vec<f64>;

    /// The curve as a chain of minor great-circle arcs, when it is one (a degree-1 B-spline):
    /// the parameter of each vertex (strictly increasing, from the domain's start to its end)
    /// and the vertices, the curve running from each vertex to the next at constant speed.
    /// Certified distances then have closed forms instead of subdivision. `None` (the
    /// default) for any other curve.
    fn as_polyline(&self) -> Option<(&[f64], &PointSet)> {
        None
    }

    /// The curve at one parameter.
    fn evaluate_at(&self, t: f64) -> Vec<f64> {
        self.evaluate_many(&[t]).get(0).to_vec()
    }

    /// `count` parameters evenly spaced over the domain (ends included) and the curve there.
    fn sample(&self, count: usize) -> (Vec<f64>, PointSet) {
        let ts = even_parameters(self.domain(), count);
        let pts = self.evaluate_many(&ts);
        (ts, pts)
    }
}

/// `count` evenly spaced values over `[a, b]`, both ends included (one value: `a`).
pub fn even_parameters((a, b): (f64, f64), count: usize) -> Vec<f64> {
    match count {
        0 => Vec::new(),
        1 => vec![a],
        _ => (0..count)
            .map(|i| {
                if i + 1 == count {
                    b
                } else {
                    a + (b - a) * i as f64 / (count - 1) as f64
                }
            })
            .collect(),
    }
}

/// Either curve: a B-spline or a Beta-spline, so output code (sampling, GeoJSON, `evaluate`) takes one
/// type.
#[derive(Clone, Debug, PartialEq)]
pub enum AnyCurve {
    /// A spherical B-spline (spline document, `sphere fit` output).
    BSpline(SphericalBSpline),
    /// A spherical Beta-spline (Beta-spline document, `sphere interpolate` output).
    Beta(SphericalBetaSpline),
}

impl SphericalCurve for AnyCurve {
    fn dim(&self) -> usize {
        match self {
            AnyCurve::BSpline(s) => s.dim(),
            AnyCurve::Beta(s) => s.dim(),
        }
    }
    fn domain(&self) -> (f64, f64) {
        match self {
            AnyCurve::BSpline(s) => s.domain(),
            AnyCurve::Beta(s) => s.domain(),
        }
    }
    fn evaluate_many(&self, ts: &[f64]) -> PointSet {
        match self {
            AnyCurve::BSpline(s) => s.evaluate_many(ts),
            AnyCurve::Beta(s) => s.evaluate_many(ts),
        }
    }
    fn evaluate_into(&self, ts: &[f64], out: &mut [f64]) {
        match self {
            AnyCurve::BSpline(s) => SphericalCurve::evaluate_into(s, ts, out),
            AnyCurve::Beta(s) => s.evaluate_into(ts, out),
        }
    }
    fn speed_bound(&self, t0: f64, t1: f64) -> f64 {
        match self {
            AnyCurve::BSpline(s) => SphericalCurve::speed_bound(s, t0, t1),
            AnyCurve::Beta(s) => s.speed_bound(t0, t1),
        }
    }
    fn acceleration_bound(&self, t0: f64, t1: f64) -> f64 {
        match self {
            AnyCurve::BSpline(s) => SphericalCurve::acceleration_bound(s, t0, t1),
            AnyCurve::Beta(s) => SphericalCurve::acceleration_bound(s, t0, t1),
        }
    }
    fn breaks(&self) -> Vec<f64> {
        match self {
            AnyCurve::BSpline(s) => s.breaks(),
            AnyCurve::Beta(s) => s.breaks(),
        }
    }
    fn as_polyline(&self) -> Option<(&[f64], &PointSet)> {
        match self {
            AnyCurve::BSpline(s) => s.as_polyline(),
            AnyCurve::Beta(_) => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn even_parameters_include_both_ends() {
        assert_eq!(even_parameters((0.0, 1.0), 3), vec![0.0, 0.5, 1.0]);
        assert_eq!(even_parameters((2.0, 3.0), 1), vec![2.0]);
        assert!(even_parameters((0.0, 1.0), 0).is_empty());
    }
}
