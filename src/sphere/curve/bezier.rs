//! Spherical Bézier curves of any degree: De Casteljau's algorithm with every affine step
//! replaced by SLERP (Beta-spline paper eqs. 1–3, after Shoemake 1985 and Popiel & Noakes 2006).
//!
//! `Q[q_0..q_n](u) = q_0^n(u)` with `q_i^k(u) = G[q_i^(k-1)(u), q_(i+1)^(k-1)(u)](u)` and
//! `G[a, b]` the great-circle arc from `a` to `b` (eq. 1). The curve starts at `q_0`, ends at
//! `q_n`, and its end velocities are `n` times those of the first and last control arcs
//! (the paper's Lemma 2): this is what makes the Beta-spline's joints G1.
//!
//! The kernel (`de_casteljau`) is generic over `Dim`, so the Beta-spline's S^2 path runs on
//! `Fixed<3>` while S^14 uses the same code with a runtime length.

use crate::sphere::certify::bounds::bezier_speed_bound;
use crate::sphere::curve::SphericalCurve;
use crate::sphere::geometry::point::{log_into, normalize, Arc, Dim, Dynamic, PointSet};
use crate::sphere::SphereError;
use rayon::prelude::*;

/// Parameters per parallel work item in [`SphericalBezier::evaluate_many`]: enough work to
/// amortise rayon's scheduling, few enough items to balance a handful of cores.
const CHUNK: usize = 4096;

/// A spherical Bézier curve on S^n of degree `control points - 1`, parameter `u` in [0, 1].
#[derive(Clone, Debug, PartialEq)]
pub struct SphericalBezier {
    control: PointSet,
}

impl SphericalBezier {
    /// A curve through `control` (unit vectors): at least 2 points (degree 1, a great-circle
    /// arc), no two consecutive points (nearly) antipodal (their arc would be undefined).
    /// Consecutive equal points are allowed: SLERP between them is constant.
    ///
    /// # Errors
    /// [`SphereError::TooFewPoints`], or [`SphereError::Antipodal`] naming the second point of
    /// the pair.
    ///
    /// # Example
    /// ```
    /// use spherefit::sphere::{PointSet, SphericalBezier};
    /// let c = PointSet::try_from_rows(&[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]).unwrap();
    /// let q = SphericalBezier::try_new(c).unwrap();
    /// assert_eq!(q.degree(), 2);
    /// assert!((q.evaluate(1.0)[2] - 1.0).abs() < 1e-15);
    /// ```
    pub fn try_new(control: PointSet) -> Result<SphericalBezier, SphereError> {
        if control.len() < 2 {
            return Err(SphereError::TooFewPoints {
                got: control.len(),
                need: 2,
            });
        }
        control.check_no_antipodal_neighbours()?;
        Ok(SphericalBezier { control })
    }

    /// A curve from control points the caller has already validated (at least 2, no
    /// antipodal neighbours): the Beta-spline's segments.
    pub(crate) fn from_valid(control: PointSet) -> SphericalBezier {
        debug_assert!(control.len() >= 2);
        SphericalBezier { control }
    }

    /// Polynomial degree n (control points - 1).
    pub fn degree(&self) -> usize {
        self.control.len() - 1
    }

    /// The control points (unit vectors).
    pub fn control_points(&self) -> &PointSet {
        &self.control
    }

    /// Number of coordinates per point.
    pub fn dim(&self) -> usize {
        self.control.dim()
    }

    /// The point Q(u) (a unit vector); `u` is clamped to [0, 1].
    pub fn evaluate(&self, u: f64) -> Vec<f64> {
        let dim = self.dim();
        let mut out = vec![0.0; dim];
        let mut scratch = vec![0.0; self.control.as_flat().len()];
        de_casteljau(
            Dynamic(dim),
            self.control.as_flat(),
            None,
            clamp_unit(u),
            &mut scratch,
            &mut out,
        );
        out
    }

    /// Q(u) at every parameter of `us` (clamped to [0, 1]), in parallel for long inputs.
    pub fn evaluate_many(&self, us: &[f64]) -> PointSet {
        let dim = self.dim();
        let mut coords = vec![0.0; us.len() * dim];
        crate::with_dim!(dim, |d| {
            let flat = self.control.as_flat();
            coords
                .par_chunks_mut(CHUNK * dim)
                .zip(us.par_chunks(CHUNK))
                .for_each(|(out, us)| {
                    let mut scratch = vec![0.0; flat.len()];
                    for (u, o) in us.iter().zip(out.chunks_exact_mut(dim)) {
                        de_casteljau(d, flat, None, clamp_unit(*u), &mut scratch, o);
                    }
                });
        });
        PointSet::from_flat_unchecked(dim, coords)
    }

    /// The velocity dQ/du at u = 0: `n · Ġ[q_0, q_1](0)`, i.e. `n` times the tangent at `q_0`
    /// towards `q_1` with length `θ(q_0, q_1)` (Lemma 2(3)). Its length is in radians per unit
    /// of `u`.
    pub fn start_velocity(&self) -> Vec<f64> {
        let n = self.control.len() - 1;
        let mut v = vec![0.0; self.dim()];
        log_into(
            Dynamic(self.dim()),
            self.control.get(0),
            self.control.get(1),
            &mut v,
        );
        v.iter_mut().for_each(|x| *x *= n as f64);
        v
    }

    /// The velocity dQ/du at u = 1: `n · Ġ[q_(n-1), q_n](1)`, the tangent at `q_n` pointing
    /// away from `q_(n-1)` with length `n θ(q_(n-1), q_n)` (Lemma 2(4)).
    pub fn end_velocity(&self) -> Vec<f64> {
        let n = self.control.len() - 1;
        let mut v = vec![0.0; self.dim()];
        log_into(
            Dynamic(self.dim()),
            self.control.get(n),
            self.control.get(n - 1),
            &mut v,
        );
        v.iter_mut().for_each(|x| *x *= -(n as f64));
        v
    }
}

impl SphericalCurve for SphericalBezier {
    fn dim(&self) -> usize {
        self.control.dim()
    }
    fn domain(&self) -> (f64, f64) {
        (0.0, 1.0)
    }
    fn evaluate_many(&self, ts: &[f64]) -> PointSet {
        SphericalBezier::evaluate_many(self, ts)
    }
    fn speed_bound(&self, t0: f64, t1: f64) -> f64 {
        let (a, b) = (clamp_unit(t0.min(t1)), clamp_unit(t0.max(t1)));
        let mut scratch = Vec::new();
        bezier_speed_bound(self.dim(), self.control.as_flat(), (a, b), &mut scratch)
    }
    fn breaks(&self) -> Vec<f64> {
        Vec::new()
    }
}

/// `u` clamped to [0, 1]; NaN becomes 0 so evaluation never reads outside the triangle.
#[inline]
fn clamp_unit(u: f64) -> f64 {
    if u.is_nan() {
        0.0
    } else {
        u.clamp(0.0, 1.0)
    }
}

/// De Casteljau with SLERP (eqs. 2–3): evaluates the Bézier curve whose `m` control points are
/// stored flat in `control` (`m * d` values) at `u`, writing the unit vector to `out`.
/// `scratch` holds at least `m * d` values. `u` is used as given (outside [0, 1] the SLERPs
/// extrapolate along their great circles). `first_arcs`, when given, are the `m - 1` arcs
/// between consecutive control points: the first level SLERPs exactly those pairs at every
/// `u`, so a curve evaluated many times computes them once.
#[inline(always)]
pub(crate) fn de_casteljau<D: Dim>(
    d: D,
    control: &[f64],
    first_arcs: Option<&[Arc]>,
    u: f64,
    scratch: &mut [f64],
    out: &mut [f64],
) {
    let dim = d.get();
    let m = control.len() / dim;
    let tri = &mut scratch[..m * dim];
    tri.copy_from_slice(&control[..m * dim]);
    // Level k overwrites point j with G[q_j, q_(j+1)](u); after m - 1 levels point 0 is Q(u).
    for level in 1..m {
        for j in 0..m - level {
            let (left, right) = tri.split_at_mut((j + 1) * dim);
            let a = &mut left[j * dim..];
            let b = &right[..dim];
            let arc = match (level, first_arcs) {
                (1, Some(arcs)) => arcs[j],
                _ => Arc::between(d, a, b),
            };
            let (w0, w1) = arc.weights(u);
            for c in 0..dim {
                a[c] = w0 * a[c] + w1 * b[c];
            }
        }
    }
    let apex = &mut tri[..dim];
    normalize(d, apex);
    out[..dim].copy_from_slice(apex);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sphere::geometry::point::{angle_between, slerp};
    use approx::assert_relative_eq;

    fn points(rows: &[[f64; 3]]) -> PointSet {
        PointSet::try_from_rows(rows).unwrap()
    }

    fn octant() -> SphericalBezier {
        let h = std::f64::consts::FRAC_1_SQRT_2;
        SphericalBezier::try_new(points(&[
            [1.0, 0.0, 0.0],
            [h, h, 0.0],
            [0.0, h, h],
            [0.0, 0.0, 1.0],
        ]))
        .unwrap()
    }

    #[test]
    fn degree_one_is_slerp() {
        let q = SphericalBezier::try_new(points(&[[1.0, 0.0, 0.0], [0.0, 0.6, 0.8]])).unwrap();
        let expected = slerp(&[1.0, 0.0, 0.0], &[0.0, 0.6, 0.8], 0.3).unwrap();
        let got = q.evaluate(0.3);
        for c in 0..3 {
            assert_relative_eq!(got[c], expected[c], epsilon = 1e-15);
        }
    }

    #[test]
    fn quadratic_matches_hand_computed_de_casteljau() {
        let (a, b, c) = ([1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]);
        let q = SphericalBezier::try_new(points(&[a, b, c])).unwrap();
        let u = 0.25;
        let ab = slerp(&a, &b, u).unwrap();
        let bc = slerp(&b, &c, u).unwrap();
        let expected = slerp(&ab, &bc, u).unwrap();
        let got = q.evaluate(u);
        for k in 0..3 {
            assert_relative_eq!(got[k], expected[k], epsilon = 1e-15);
        }
    }

    #[test]
    fn ends_interpolate_and_parameters_clamp() {
        let q = octant();
        let c = q.control_points();
        assert!(angle_between(&q.evaluate(0.0), c.get(0)) < 1e-15);
        assert!(angle_between(&q.evaluate(1.0), c.get(3)) < 1e-15);
        assert_eq!(q.evaluate(-3.0), q.evaluate(0.0));
        assert_eq!(q.evaluate(7.0), q.evaluate(1.0));
        assert_eq!(q.evaluate(f64::NAN), q.evaluate(0.0));
    }

    #[test]
    fn results_are_unit_vectors_in_every_dimension() {
        for dim in [3, 4, 15] {
            let rows: Vec<Vec<f64>> = (0..5)
                .map(|i| {
                    let mut v: Vec<f64> = (0..dim).map(|k| ((i * dim + k) as f64).sin()).collect();
                    normalize(Dynamic(dim), &mut v);
                    v
                })
                .collect();
            let q = SphericalBezier::try_new(PointSet::try_from_rows(&rows).unwrap()).unwrap();
            let pts = q.evaluate_many(&[0.0, 0.1, 0.5, 0.9, 1.0]);
            for p in pts.iter() {
                let n: f64 = p.iter().map(|x| x * x).sum::<f64>().sqrt();
                assert!((n - 1.0).abs() < 1e-14);
            }
            assert_eq!(pts.get(2), &q.evaluate(0.5)[..]);
        }
    }

    #[test]
    fn end_velocities_match_finite_differences() {
        let q = octant();
        let (v0, v1) = (q.start_velocity(), q.end_velocity());
        // Second-order one-sided differences: error O(h^2).
        let h = 1e-5;
        let (p0, p1, p2) = (q.evaluate(0.0), q.evaluate(h), q.evaluate(2.0 * h));
        let (r0, r1, r2) = (
            q.evaluate(1.0),
            q.evaluate(1.0 - h),
            q.evaluate(1.0 - 2.0 * h),
        );
        for c in 0..3 {
            let fd0 = (-3.0 * p0[c] + 4.0 * p1[c] - p2[c]) / (2.0 * h);
            let fd1 = (3.0 * r0[c] - 4.0 * r1[c] + r2[c]) / (2.0 * h);
            assert_relative_eq!(v0[c], fd0, epsilon = 1e-8);
            assert_relative_eq!(v1[c], fd1, epsilon = 1e-8);
        }
        // |v(0)| = 3 θ(q0, q1) = 3 π/4.
        let len: f64 = v0.iter().map(|x| x * x).sum::<f64>().sqrt();
        assert_relative_eq!(len, 0.75 * std::f64::consts::PI, epsilon = 1e-14);
    }

    #[test]
    fn rejects_short_and_antipodal_control_polygons() {
        let e = SphericalBezier::try_new(points(&[[1.0, 0.0, 0.0]])).unwrap_err();
        assert!(matches!(e, SphereError::TooFewPoints { got: 1, need: 2 }));
        let e = SphericalBezier::try_new(points(&[
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, -1.0, 0.0],
        ]))
        .unwrap_err();
        assert!(matches!(e, SphereError::Antipodal { index: 2, .. }));
    }
}
