//! The cubic spherical Beta-spline (Yang, Wang, Chen, Sun, He 2021, "Research on the spherical
//! Beta spline curve"; reconstruction in `METHOD.md`). Interpolation with it, solving for the
//! auxiliary vertices, is [`crate::sphere::interpolate::beta`].
//!
//! # The curve (eqs. 4–7)
//! Given auxiliary vertices `d_0..d_n` and per-point shape parameters `beta1_j > 0` (bias: the
//! ratio of outgoing to incoming speed at point j) and `beta2_j >= 0` (tension), segment `i`
//! (0-based here, parameter `[i, i+1]`) is the cubic spherical Bézier curve
//! `[q_(i,0), q_(i,1), q_(i,2), q_(i,3) = q_(i+1,0)]` with
//! * `gamma_j = 2 (beta1_j + 1) / (beta2_j + 2 beta1_j (beta1_j + 1))` (eq. 7);
//! * the leg `d_i d_(i+1)` cut in the ratio `gamma_i : 1 : beta1_(i+1)^2 gamma_(i+1)`:
//!   `q_(i,1) = G[d_i, d_(i+1)](gamma_i / S)`, `q_(i,2) = G[d_i, d_(i+1)]((gamma_i + 1) / S)`,
//!   `S = gamma_i + 1 + beta1_(i+1)^2 gamma_(i+1)` (eqs. 4–5, with the square as printed there:
//!   it is what the Euclidean G2 condition gives; eq. 14 drops it, an inconsistency METHOD.md
//!   documents);
//! * `q_(j,0) = G[q_(j-1,2), q_(j,1)](1 / (1 + beta1_j))` at interior points, `d_0` and `d_n` at
//!   the ends (eq. 6, with the index slip of eq. 6 and Theorem 1 corrected: point j uses
//!   `beta1_j`, so `|outgoing| / |incoming| = beta1_j` there).
//!
//! The curve is G1 at every joint (Theorem 1). With `beta1 = 1, beta2 = 0` the legs are cut in
//! thirds and the ends have zero second derivative: in the small-data limit it is the natural
//! C2 cubic interpolating spline with uniform parameters.
//! Hot loops are generic over `Dim`, so S^2 runs on `Fixed<3>`.

use crate::sphere::certify::bounds::bezier_speed_bound;
use crate::sphere::curve::bezier::{de_casteljau, SphericalBezier};
use crate::sphere::curve::SphericalCurve;
use crate::sphere::geometry::point::{normalize, Arc, Dim, PointSet};
use crate::sphere::SphereError;
use rayon::prelude::*;

/// Smallest and largest accepted `beta1`. Outside, `beta1^2 gamma` over- or underflows
/// relative to 1 and the arc fractions of eqs. 4–5 lose every digit.
pub const BETA1_RANGE: (f64, f64) = (1e-6, 1e6);

/// Evaluation parameters per parallel work item.
const CHUNK: usize = 4096;

/// `gamma = 2 (beta1 + 1) / (beta2 + 2 beta1 (beta1 + 1))` (eq. 7): the share of a leg that
/// ties the second derivatives at a joint together (G2 in the Euclidean Beta-spline).
pub fn gamma(beta1: f64, beta2: f64) -> f64 {
    2.0 * (beta1 + 1.0) / (beta2 + 2.0 * beta1 * (beta1 + 1.0))
}

/// Validates shape parameters for `count` points: one value (used everywhere) or one per
/// point; `beta1` in [`BETA1_RANGE`], `beta2` finite and >= 0. Returns one value per point.
///
/// # Errors
/// [`SphereError::ShapeParameterCount`] or [`SphereError::InvalidShapeParameter`] naming the
/// field (`beta1`/`beta2`) and the index.
pub fn expand_shape_parameters(
    beta1: &[f64],
    beta2: &[f64],
    count: usize,
) -> Result<(Vec<f64>, Vec<f64>), SphereError> {
    let expand = |field: &'static str, v: &[f64]| -> Result<Vec<f64>, SphereError> {
        match v.len() {
            1 => Ok(vec![v[0]; count]),
            n if n == count => Ok(v.to_vec()),
            got => Err(SphereError::ShapeParameterCount {
                field,
                expected: count,
                got,
            }),
        }
    };
    let (b1, b2) = (expand("beta1", beta1)?, expand("beta2", beta2)?);
    if let Some(index) = b1
        .iter()
        .position(|b| !(b.is_finite() && *b >= BETA1_RANGE.0 && *b <= BETA1_RANGE.1))
    {
        return Err(SphereError::InvalidShapeParameter {
            field: "beta1",
            index,
            value: b1[index],
            rule: "beta1 must be a finite number from 1e-6 to 1e6 (the ratio of outgoing to incoming speed)",
        });
    }
    if let Some(index) = b2.iter().position(|b| !(b.is_finite() && *b >= 0.0)) {
        return Err(SphereError::InvalidShapeParameter {
            field: "beta2",
            index,
            value: b2[index],
            rule: "beta2 must be a finite number >= 0 (the tension)",
        });
    }
    Ok((b1, b2))
}

/// The SLERP fractions of eqs. 4–6: all the construction and the solvers need from the shape
/// parameters. Leg `l` runs from `d_l` to `d_(l+1)`.
#[derive(Clone, Debug)]
pub(crate) struct Fractions {
    /// `q_(l,1) = G[d_l, d_(l+1)](first[l])` (eq. 4).
    pub(crate) first: Vec<f64>,
    /// `q_(l,2) = G[d_l, d_(l+1)](second[l])` (eq. 5).
    pub(crate) second: Vec<f64>,
    /// `q_(j,0) = G[q_(j-1,2), q_(j,1)](junction[j])` = `1 / (1 + beta1_j)` (eq. 6).
    pub(crate) junction: Vec<f64>,
}

impl Fractions {
    pub(crate) fn new(beta1: &[f64], beta2: &[f64]) -> Fractions {
        let g: Vec<f64> = beta1
            .iter()
            .zip(beta2)
            .map(|(&a, &b)| gamma(a, b))
            .collect();
        let legs = beta1.len() - 1;
        let (mut first, mut second) = (Vec::with_capacity(legs), Vec::with_capacity(legs));
        for l in 0..legs {
            let s = g[l] + 1.0 + beta1[l + 1] * beta1[l + 1] * g[l + 1];
            first.push(g[l] / s);
            second.push((g[l] + 1.0) / s);
        }
        let junction = beta1.iter().map(|b| 1.0 / (1.0 + b)).collect();
        Fractions {
            first,
            second,
            junction,
        }
    }
}

/// A cubic spherical Beta-spline on S^n: `n` cubic spherical Bézier segments, segment `i`
/// spanning parameter `[i, i + 1]`, with the shape parameters it was built with.
#[derive(Clone, Debug, PartialEq)]
pub struct SphericalBetaSpline {
    beta1: Vec<f64>,
    beta2: Vec<f64>,
    /// `3 n + 1` Bézier control points; segment i is `control[3i ..= 3i + 3]`.
    control: PointSet,
    /// `arcs[k]`: the arc from control point k to k + 1 (3 n of them), cached for evaluation.
    arcs: Vec<Arc>,
}

impl SphericalBetaSpline {
    /// Builds the Beta-spline of auxiliary vertices `aux` (eqs. 4–7). `beta1`, `beta2`: one
    /// value for every point or one per point.
    ///
    /// # Errors
    /// Fewer than 2 vertices, bad shape parameters (field and index named), or an arc of
    /// (nearly) half a great circle between consecutive vertices or across a joint
    /// ([`SphereError::DegenerateArc`] naming the point).
    pub fn try_from_auxiliary(
        aux: &PointSet,
        beta1: &[f64],
        beta2: &[f64],
    ) -> Result<SphericalBetaSpline, SphereError> {
        if aux.len() < 2 {
            return Err(SphereError::TooFewPoints {
                got: aux.len(),
                need: 2,
            });
        }
        let (beta1, beta2) = expand_shape_parameters(beta1, beta2, aux.len())?;
        let fr = Fractions::new(&beta1, &beta2);
        let control = crate::with_dim!(aux.dim(), |d| build_control(d, aux, &fr))?;
        Ok(SphericalBetaSpline::from_parts(beta1, beta2, control))
    }

    /// Assembles a spline from validated parts (shape parameters one per point, `3 n + 1`
    /// control points without antipodal neighbours).
    pub(crate) fn from_parts(
        beta1: Vec<f64>,
        beta2: Vec<f64>,
        control: PointSet,
    ) -> SphericalBetaSpline {
        let arcs = crate::with_dim!(control.dim(), |d| (1..control.len())
            .map(|k| Arc::between(d, control.get(k - 1), control.get(k)))
            .collect());
        SphericalBetaSpline {
            beta1,
            beta2,
            control,
            arcs,
        }
    }

    /// `beta1` at every point (the speed ratio out / in at interior points).
    pub fn beta1(&self) -> &[f64] {
        &self.beta1
    }

    /// `beta2` at every point (tension).
    pub fn beta2(&self) -> &[f64] {
        &self.beta2
    }

    /// Numbers needed to rebuild the curve: `dim − 1` per Bézier control point (a joint shared
    /// by two segments counted once) and both shape parameters at every point.
    pub fn stored_numbers(&self) -> usize {
        (self.dim() - 1) * self.control.len() + self.beta1.len() + self.beta2.len()
    }

    /// Number of cubic segments (points - 1).
    pub fn segment_count(&self) -> usize {
        (self.control.len() - 1) / 3
    }

    /// Number of coordinates per point.
    pub fn dim(&self) -> usize {
        self.control.dim()
    }

    /// All `3 n + 1` Bézier control points, joints shared: segment i is points `3i ..= 3i + 3`.
    pub fn control_points(&self) -> &PointSet {
        &self.control
    }

    /// The curve at parameter j (`q_(j,0)`), j = 0 ..= segments.
    pub fn joint(&self, j: usize) -> &[f64] {
        self.control.get(3 * j)
    }

    /// Segment `i` as a spherical Bézier curve on `u = t - i` in [0, 1], or `None` past the end.
    pub fn segment(&self, i: usize) -> Option<SphericalBezier> {
        if i >= self.segment_count() {
            return None;
        }
        let dim = self.dim();
        let flat = self.control.as_flat()[3 * i * dim..(3 * i + 4) * dim].to_vec();
        Some(SphericalBezier::from_valid(PointSet::from_flat_unchecked(
            dim, flat,
        )))
    }

    /// Parameter domain `[0, segments]`.
    pub fn domain(&self) -> (f64, f64) {
        (0.0, self.segment_count() as f64)
    }

    /// The point at parameter `t` (clamped to the domain; NaN reads as 0).
    pub fn evaluate(&self, t: f64) -> Vec<f64> {
        self.evaluate_many(&[t]).get(0).to_vec()
    }

    /// The curve at every parameter of `ts`, in parallel for long inputs.
    pub fn evaluate_many(&self, ts: &[f64]) -> PointSet {
        let dim = self.dim();
        let mut coords = vec![0.0; ts.len() * dim];
        crate::with_dim!(dim, |d| self.evaluate_into(d, ts, &mut coords));
        PointSet::from_flat_unchecked(dim, coords)
    }

    fn evaluate_into<D: Dim>(&self, d: D, ts: &[f64], coords: &mut [f64]) {
        let dim = d.get();
        let flat = self.control.as_flat();
        let n = self.segment_count();
        coords
            .par_chunks_mut(CHUNK * dim)
            .zip(ts.par_chunks(CHUNK))
            .for_each(|(out, ts)| {
                let mut scratch = vec![0.0; 4 * dim];
                for (t, o) in ts.iter().zip(out.chunks_exact_mut(dim)) {
                    let (seg, u) = locate(n, *t);
                    let ctrl = &flat[3 * seg * dim..(3 * seg + 4) * dim];
                    let arcs = &self.arcs[3 * seg..3 * seg + 3];
                    de_casteljau(d, ctrl, Some(arcs), u, &mut scratch, o);
                }
            });
    }
}

/// Segment index and local parameter of global parameter `t` on `n` segments.
#[inline(always)]
fn locate(n: usize, t: f64) -> (usize, f64) {
    let t = if t.is_nan() {
        0.0
    } else {
        t.clamp(0.0, n as f64)
    };
    let seg = (t.floor() as usize).min(n - 1);
    (seg, t - seg as f64)
}

impl SphericalCurve for SphericalBetaSpline {
    fn dim(&self) -> usize {
        self.control.dim()
    }
    fn domain(&self) -> (f64, f64) {
        SphericalBetaSpline::domain(self)
    }
    fn evaluate_many(&self, ts: &[f64]) -> PointSet {
        SphericalBetaSpline::evaluate_many(self, ts)
    }
    fn speed_bound(&self, t0: f64, t1: f64) -> f64 {
        // Segment i is a cubic de Casteljau triangle on u = t - i (alpha = u, slope 1).
        let n = self.segment_count();
        let (t0, t1) = (t0.clamp(0.0, n as f64), t1.clamp(0.0, n as f64));
        let (t0, t1) = (t0.min(t1), t0.max(t1));
        let dim = self.dim();
        let flat = self.control.as_flat();
        let mut scratch = Vec::with_capacity(4 * dim);
        let mut best: f64 = 0.0;
        let mut seg = (t0.floor() as usize).min(n - 1);
        loop {
            let (a, b) = (
                (t0 - seg as f64).clamp(0.0, 1.0),
                (t1 - seg as f64).clamp(0.0, 1.0),
            );
            let ctrl = &flat[3 * seg * dim..(3 * seg + 4) * dim];
            let s = bezier_speed_bound(dim, ctrl, (a, b), &mut scratch);
            best = best.max(s);
            seg += 1;
            if seg >= n || seg as f64 >= t1 {
                break;
            }
        }
        best
    }
    fn breaks(&self) -> Vec<f64> {
        (1..self.segment_count()).map(|i| i as f64).collect()
    }
}

/// The point `F_j` at interior joint j for auxiliary vertices `aux` (flat), and the weights of
/// its three SLERPs (eqs. 15–17): `A = q_(j-1,2)`, `B = q_(j,1)`, `F = G[A, B](junction_j)`.
pub(crate) struct JointEval {
    pub(crate) arc_a: Arc,
    pub(crate) wa: (f64, f64),
    pub(crate) arc_b: Arc,
    pub(crate) wb: (f64, f64),
    pub(crate) arc_f: Arc,
    pub(crate) wf: (f64, f64),
}

impl JointEval {
    /// Weights of `d_(j-1)`, `d_j`, `d_(j+1)` in `F_j` (eq. 18 divided by sin psi_j).
    #[inline(always)]
    pub(crate) fn coefficients(&self) -> (f64, f64, f64) {
        (
            self.wf.0 * self.wa.0,
            self.wf.0 * self.wa.1 + self.wf.1 * self.wb.0,
            self.wf.1 * self.wb.1,
        )
    }
}

#[inline(always)]
pub(crate) fn eval_joint<D: Dim>(
    d: D,
    aux: &[f64],
    fr: &Fractions,
    j: usize,
    a: &mut [f64],
    b: &mut [f64],
    f: &mut [f64],
) -> JointEval {
    let dim = d.get();
    let (dm, dj, dp) = (
        &aux[(j - 1) * dim..j * dim],
        &aux[j * dim..(j + 1) * dim],
        &aux[(j + 1) * dim..(j + 2) * dim],
    );
    let arc_a = Arc::between(d, dm, dj);
    let wa = arc_a.weights(fr.second[j - 1]);
    let arc_b = Arc::between(d, dj, dp);
    let wb = arc_b.weights(fr.first[j]);
    for c in 0..dim {
        a[c] = wa.0 * dm[c] + wa.1 * dj[c];
        b[c] = wb.0 * dj[c] + wb.1 * dp[c];
    }
    normalize(d, a);
    normalize(d, b);
    let arc_f = Arc::between(d, a, b);
    let wf = arc_f.weights(fr.junction[j]);
    for c in 0..dim {
        f[c] = wf.0 * a[c] + wf.1 * b[c];
    }
    normalize(d, f);
    JointEval {
        arc_a,
        wa,
        arc_b,
        wb,
        arc_f,
        wf,
    }
}

/// The `3 n + 1` control points of eqs. 4–6 from auxiliary vertices.
pub(crate) fn build_control<D: Dim>(
    d: D,
    aux: &PointSet,
    fr: &Fractions,
) -> Result<PointSet, SphereError> {
    let (dim, n) = (d.get(), aux.len() - 1);
    let flat = aux.as_flat();
    let interior = |l: usize| if l + 1 < n { l + 1 } else { l };
    let mut control = vec![0.0; (3 * n + 1) * dim];
    control[..dim].copy_from_slice(aux.get(0));
    control[3 * n * dim..].copy_from_slice(aux.get(n));
    for l in 0..n {
        let arc = Arc::between(d, aux.get(l), aux.get(l + 1));
        if arc.is_near_antipodal() || arc.theta.is_nan() {
            return Err(SphereError::DegenerateArc {
                joint: interior(l),
                angle_rad: arc.theta,
            });
        }
        for (k, t) in [(1, fr.first[l]), (2, fr.second[l])] {
            let (w0, w1) = arc.weights(t);
            let out = &mut control[(3 * l + k) * dim..(3 * l + k + 1) * dim];
            for c in 0..dim {
                out[c] = w0 * flat[l * dim + c] + w1 * flat[(l + 1) * dim + c];
            }
            normalize(d, out);
        }
    }
    let (mut a, mut b, mut f) = (vec![0.0; dim], vec![0.0; dim], vec![0.0; dim]);
    for j in 1..n {
        let e = eval_joint(d, flat, fr, j, &mut a, &mut b, &mut f);
        if e.arc_f.is_near_antipodal() {
            return Err(SphereError::DegenerateArc {
                joint: j,
                angle_rad: e.arc_f.theta,
            });
        }
        control[3 * j * dim..(3 * j + 1) * dim].copy_from_slice(&f);
    }
    Ok(PointSet::from_flat_unchecked(dim, control))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sphere::geometry::point::angle_between;
    use crate::sphere::interpolate::beta::{interpolate, InterpolationOptions};
    use crate::sphere::interpolate::paper_examples::example1;
    use approx::assert_relative_eq;

    #[test]
    fn gamma_is_one_for_the_neutral_parameters() {
        assert_eq!(gamma(1.0, 0.0), 1.0);
        // beta2 = 0: beta1 gamma = 1, so beta1^2 gamma = beta1.
        assert_relative_eq!(0.5 * gamma(0.5, 0.0), 1.0, epsilon = 1e-15);
        let f = Fractions::new(&[1.0; 3], &[0.0; 3]);
        assert_relative_eq!(f.first[0], 1.0 / 3.0, epsilon = 1e-15);
        assert_relative_eq!(f.second[1], 2.0 / 3.0, epsilon = 1e-15);
        assert_eq!(f.junction[1], 0.5);
    }

    #[test]
    fn construction_matches_eqs_4_to_6() {
        let aux = example1();
        let s = SphericalBetaSpline::try_from_auxiliary(&aux, &[1.0], &[0.0]).unwrap();
        assert_eq!(s.segment_count(), 3);
        let slerp = crate::sphere::geometry::point::slerp;
        let q01 = slerp(aux.get(0), aux.get(1), 1.0 / 3.0).unwrap();
        let q02 = slerp(aux.get(0), aux.get(1), 2.0 / 3.0).unwrap();
        let q11 = slerp(aux.get(1), aux.get(2), 1.0 / 3.0).unwrap();
        let q10 = slerp(&q02, &q11, 0.5).unwrap();
        for (got, want) in [
            (s.control_points().get(1), &q01),
            (s.control_points().get(2), &q02),
            (s.joint(1), &q10),
        ] {
            assert!(angle_between(got, want) < 1e-15);
        }
        assert_eq!(s.joint(0), aux.get(0));
        assert_eq!(s.joint(3), aux.get(3));
    }

    #[test]
    fn evaluation_clamps_and_segments_join() {
        let r = interpolate(&example1(), &InterpolationOptions::default()).unwrap();
        let s = &r.spline;
        assert_eq!(s.evaluate(-1.0), s.evaluate(0.0));
        assert_eq!(s.evaluate(9.0), s.evaluate(3.0));
        assert_eq!(s.evaluate(f64::NAN), s.evaluate(0.0));
        let left = s.segment(0).unwrap().evaluate(1.0);
        assert!(angle_between(&left, &s.evaluate(1.0)) < 1e-15);
        assert!(s.segment(3).is_none());
    }
}
