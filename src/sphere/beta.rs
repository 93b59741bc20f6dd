//! The cubic spherical Beta-spline and interpolation with it (Yang, Wang, Chen, Sun, He 2021,
//! "Research on the spherical Beta spline curve"; reconstruction in `METHOD.md`).
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
//!
//! # Interpolation (eqs. 13, 18, 19)
//! Setting `q_(j,0) = q_j` gives one equation per interior point, `F_j(d_(j-1), d_j, d_(j+1)) =
//! q_j` with `d_0 = q_0`, `d_n = q_n` (Theorem 2). The paper solves it with a Jacobi iteration
//! (eq. 19) stopped when `Σ |d^k - d^(k-1)|^2 < 1e-5`, which leaves errors of 3e-3 rad. Here
//! every solver runs to a residual of [`SOLVER_TARGET_RAD`] (or until it stops improving), and
//! the result is always checked: the angle between the curve at parameter j and `q_j` must be
//! at most the tolerance ([`INTERPOLATION_TOLERANCE_RAD`] by default) at every point, or
//! [`interpolate`] fails with [`SphereError::NotInterpolated`] naming the worst point.
//!
//! # Solver
//! [`BetaSolver::Newton`] (default) linearises all equations at once: the chain-rule Jacobians
//! of the three SLERPs of eqs. 15–17, restricted to the tangent spaces at the `d_j`, form a
//! block-tridiagonal system solved by banded LU with partial pivoting, followed by a
//! backtracking line search on `Σ θ_j^2`. [`BetaSolver::Jacobi`] is the paper's eq. 19, each
//! new `d_j` re-normalised. Measured (`benches/beta.rs` and a solver comparison, 10k points on
//! S^2, beta1 = 1, to 1e-15 rad): Newton 1–2 steps, about 10 ms; eq. 19 32–38 sweeps, about
//! 100 ms; Gauss–Seidel (eq. 19 reading the updated `d_(j-1)`) 17–21 sweeps, about 70 ms; a
//! frozen-coefficient solve of eq. 13 as a tridiagonal system 2–5 steps, about as fast as
//! Newton on dense data but 25–126 steps on the paper's examples. Newton needs 4–6 steps on the
//! paper's examples and is the only one that converges for Example 2 with beta1 = 0.3 at q2
//! (eq. 19 stalls with a residual of 1.7e-5 rad after 5000 sweeps), so it is the default and
//! the other two were dropped; eq. 19 stays for reproducing the paper.
//!
//! # Limits
//! * Consecutive points must differ (more than [`REPEATED_POINT_RAD`]) and not be antipodal.
//! * Shape parameters far from 1 near a sharp turn can need auxiliary arcs of half a great
//!   circle or more: there is no spherical curve then, and the error names the point
//!   (Example 2 with beta1 = 0.1 at q2, or 0.01 or 10 at q1).
//! * A beta1 held away from 1 over many consecutive points has no bounded solution: in the
//!   small-data limit eq. 13 is a tridiagonal Toeplitz system that is solvable along arbitrarily
//!   long inputs only while the weight of `d_j` exceeds 1/2, which with `beta2 = 0` means
//!   `1/φ^2 = 0.382 < beta1 < φ^2 = 2.618` (φ the golden ratio; `beta2 = 1` lowers the bound
//!   to 0.21, large `beta2` barely moves the upper one). Outside, the end condition `d_n = q_n`
//!   is met only by a correction growing geometrically along the curve, and interpolation of
//!   more than a few dozen points fails. Use beta1 to shape a few joints, not as a global bias.
//!
//! Hot loops are generic over [`Dim`], so S^2 runs on `Fixed<3>`.

use super::bezier::{de_casteljau, log_into, SphericalBezier};
use super::bspline::SphericalBSpline;
use super::curve::SphericalCurve;
use super::document::{number_list, number_rows, pointer_for, spline_from_json, InputError};
use super::point::{angle, normalize, Arc, Dim, Dynamic, PointSet};
use super::SphereError;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use serde_json::Value;

/// Default acceptance threshold for the interpolation residual, in radians (6 µm on the Earth):
/// far below any data precision, and 1000 times above the rounding floor the solvers reach.
pub const INTERPOLATION_TOLERANCE_RAD: f64 = 1e-12;

/// The solvers stop once every point is matched to this many radians: a few units in the last
/// place of an angle, about the rounding floor of evaluating three SLERPs.
pub const SOLVER_TARGET_RAD: f64 = 1e-15;

/// Consecutive points closer than this are "the same point" (0.6 mm on the Earth): the segment
/// between them would have to turn around inside it, and tangents computed from points this
/// close have relative errors above 1e-6.
pub const REPEATED_POINT_RAD: f64 = 1e-10;

/// Smallest and largest accepted `beta1`. Outside, `beta1^2 gamma` over- or underflows
/// relative to 1 and the arc fractions of eqs. 4–5 lose every digit.
pub const BETA1_RANGE: (f64, f64) = (1e-6, 1e6);

/// In a Beta-spline document, the first control point of segment i must match the last of
/// segment i - 1 within this angle (radians): room for decimal printing of the same number by
/// another program, nothing more.
pub const JOINT_MATCH_RAD: f64 = 1e-12;

/// Default iteration limit of [`BetaSolver::Newton`]; it converges in under 10 steps on every
/// input measured, so 50 only matters for inputs it cannot solve.
pub const DEFAULT_NEWTON_ITERATIONS: usize = 50;

/// Default iteration limit of the fixed-point solvers (eq. 19): their rate is about 1/2
/// (Jacobi) or 1/4 (Gauss–Seidel) per iteration at `beta1 = 1`, much slower when `beta1` is far
/// from 1.
pub const DEFAULT_FIXED_POINT_ITERATIONS: usize = 5000;

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
struct Fractions {
    /// `q_(l,1) = G[d_l, d_(l+1)](first[l])` (eq. 4).
    first: Vec<f64>,
    /// `q_(l,2) = G[d_l, d_(l+1)](second[l])` (eq. 5).
    second: Vec<f64>,
    /// `q_(j,0) = G[q_(j-1,2), q_(j,1)](junction[j])` = `1 / (1 + beta1_j)` (eq. 6).
    junction: Vec<f64>,
}

impl Fractions {
    fn new(beta1: &[f64], beta2: &[f64]) -> Fractions {
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
    fn from_parts(beta1: Vec<f64>, beta2: Vec<f64>, control: PointSet) -> SphericalBetaSpline {
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
}

/// The point `F_j` at interior joint j for auxiliary vertices `aux` (flat), and the weights of
/// its three SLERPs (eqs. 15–17): `A = q_(j-1,2)`, `B = q_(j,1)`, `F = G[A, B](junction_j)`.
struct JointEval {
    arc_a: Arc,
    wa: (f64, f64),
    arc_b: Arc,
    wb: (f64, f64),
    arc_f: Arc,
    wf: (f64, f64),
}

impl JointEval {
    /// Weights of `d_(j-1)`, `d_j`, `d_(j+1)` in `F_j` (eq. 18 divided by sin psi_j).
    #[inline(always)]
    fn coefficients(&self) -> (f64, f64, f64) {
        (
            self.wf.0 * self.wa.0,
            self.wf.0 * self.wa.1 + self.wf.1 * self.wb.0,
            self.wf.1 * self.wb.1,
        )
    }
}

#[inline(always)]
fn eval_joint<D: Dim>(
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
fn build_control<D: Dim>(d: D, aux: &PointSet, fr: &Fractions) -> Result<PointSet, SphereError> {
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

/// How [`interpolate`] solves eq. 13 for the auxiliary vertices.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum BetaSolver {
    /// Newton's method on the tangent spaces with a banded LU solve and line search: 3–5
    /// steps, robust to extreme shape parameters. The default.
    #[default]
    Newton,
    /// The paper's iteration (eq. 19), every vertex from the previous iterate, re-normalised.
    Jacobi,
}

impl std::str::FromStr for BetaSolver {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "newton" => Ok(BetaSolver::Newton),
            "jacobi" => Ok(BetaSolver::Jacobi),
            _ => Err(format!("unknown solver {s:?}: use newton or jacobi")),
        }
    }
}

/// Shape parameters and solver settings for [`interpolate`]. `Default`: `beta1 = 1`,
/// `beta2 = 0` everywhere (the natural cubic spline in the small-data limit), Newton,
/// tolerance [`INTERPOLATION_TOLERANCE_RAD`].
#[derive(Clone, Debug, PartialEq)]
pub struct InterpolationOptions {
    /// `beta1`: one value for every point, or one per point.
    pub beta1: Vec<f64>,
    /// `beta2`: one value for every point, or one per point.
    pub beta2: Vec<f64>,
    /// Solver for the auxiliary vertices.
    pub solver: BetaSolver,
    /// Iteration limit; `None` uses the solver's default.
    pub max_iterations: Option<usize>,
    /// Largest accepted angle between the curve at parameter j and point j, radians.
    pub tolerance_rad: f64,
    /// Stops the solver (with [`SphereError::Cancelled`]) when cancelled or past its deadline.
    pub cancel: super::cancel::Cancel,
}

impl Default for InterpolationOptions {
    fn default() -> Self {
        InterpolationOptions {
            beta1: vec![1.0],
            beta2: vec![0.0],
            solver: BetaSolver::Newton,
            max_iterations: None,
            tolerance_rad: INTERPOLATION_TOLERANCE_RAD,
            cancel: super::cancel::Cancel::inherit(),
        }
    }
}

impl InterpolationOptions {
    /// The same `beta1` at every point.
    pub fn with_beta1(mut self, beta1: f64) -> Self {
        self.beta1 = vec![beta1];
        self
    }
    /// One `beta1` per point.
    pub fn with_beta1_per_point(mut self, beta1: Vec<f64>) -> Self {
        self.beta1 = beta1;
        self
    }
    /// The same `beta2` at every point.
    pub fn with_beta2(mut self, beta2: f64) -> Self {
        self.beta2 = vec![beta2];
        self
    }
    /// One `beta2` per point.
    pub fn with_beta2_per_point(mut self, beta2: Vec<f64>) -> Self {
        self.beta2 = beta2;
        self
    }
    /// Sets the solver.
    pub fn with_solver(mut self, solver: BetaSolver) -> Self {
        self.solver = solver;
        self
    }
    /// Sets the iteration limit.
    pub fn with_max_iterations(mut self, n: usize) -> Self {
        self.max_iterations = Some(n);
        self
    }
    /// Sets the accepted residual in radians.
    pub fn with_tolerance_rad(mut self, tolerance_rad: f64) -> Self {
        self.tolerance_rad = tolerance_rad;
        self
    }
}

/// An interpolating Beta-spline and how well and how fast it was found.
#[derive(Clone, Debug, PartialEq)]
pub struct BetaInterpolation {
    /// The curve; `spline.evaluate(j as f64)` is point j to within `residual_rad`.
    pub spline: SphericalBetaSpline,
    /// The auxiliary vertices `d_j` that define it.
    pub auxiliary: PointSet,
    /// Largest angle between the curve at parameter j and point j, radians.
    pub residual_rad: f64,
    /// The point where `residual_rad` occurs.
    pub residual_index: usize,
    /// Solver steps taken.
    pub iterations: usize,
}

/// The cubic spherical Beta-spline through `points` (in order, parameter j at point j) with
/// the shape parameters of `options` (paper §4: auxiliary vertices from eq. 13, curve from
/// eqs. 4–7). Works on any S^n (n >= 1).
///
/// # Errors
/// * fewer than 2 points; bad shape parameters (field and index);
/// * [`SphereError::RepeatedPoint`] / [`SphereError::Antipodal`] for consecutive points that
///   coincide (within [`REPEATED_POINT_RAD`]) or are (nearly) antipodal, naming the second;
/// * [`SphereError::NotInterpolated`] when the solver stops with a residual above
///   `options.tolerance_rad`, naming the worst point; [`SphereError::DegenerateArc`] when the
///   solution needs a half great circle. Both mean the shape parameters cannot be met there.
///
/// # Example
/// ```
/// use spherefit::sphere::{interpolate, InterpolationOptions, PointSet, SphericalCurve};
/// let points = PointSet::try_from_rows(&[
///     [1.0, 0.0, 0.0], [0.8, 0.6, 0.0], [0.6, 0.6, 0.52915], [0.0, 0.6, 0.8],
/// ]).unwrap();
/// let r = interpolate(&points, &InterpolationOptions::default().with_beta1(0.8)).unwrap();
/// assert!(r.residual_rad <= 1e-12);
/// assert_eq!(r.spline.domain(), (0.0, 3.0));
/// ```
pub fn interpolate(
    points: &PointSet,
    options: &InterpolationOptions,
) -> Result<BetaInterpolation, SphereError> {
    if points.len() < 2 {
        return Err(SphereError::TooFewPoints {
            got: points.len(),
            need: 2,
        });
    }
    check_neighbours(points)?;
    let (beta1, beta2) = expand_shape_parameters(&options.beta1, &options.beta2, points.len())?;
    let fr = Fractions::new(&beta1, &beta2);
    let max_iterations = options.max_iterations.unwrap_or(match options.solver {
        BetaSolver::Newton => DEFAULT_NEWTON_ITERATIONS,
        _ => DEFAULT_FIXED_POINT_ITERATIONS,
    });
    let scope = options.cancel.enter();
    let (aux, iterations) = crate::with_dim!(points.dim(), |d| solve(
        d,
        points,
        &fr,
        options.solver,
        max_iterations
    ));
    drop(scope);
    options.cancel.check()?;
    let auxiliary = PointSet::from_flat_unchecked(points.dim(), aux);
    let control = crate::with_dim!(points.dim(), |d| build_control(d, &auxiliary, &fr))?;
    let spline = SphericalBetaSpline::from_parts(beta1, beta2, control);
    // The check that makes failure explicit: measure the finished curve, not the solver.
    let (mut residual_rad, mut residual_index) = (0.0_f64, 0);
    let d = Dynamic(points.dim());
    for j in 0..points.len() {
        let e = angle(d, spline.joint(j), points.get(j));
        if e.is_nan() || e > residual_rad {
            residual_rad = if e.is_nan() { f64::INFINITY } else { e };
            residual_index = j;
        }
    }
    if residual_rad > options.tolerance_rad || options.tolerance_rad.is_nan() {
        return Err(SphereError::NotInterpolated {
            joint: residual_index,
            residual_rad,
            tolerance_rad: options.tolerance_rad,
            iterations,
        });
    }
    Ok(BetaInterpolation {
        spline,
        auxiliary,
        residual_rad,
        residual_index,
        iterations,
    })
}

/// Repeated and (nearly) antipodal consecutive points, named by the second of the pair.
fn check_neighbours(points: &PointSet) -> Result<(), SphereError> {
    let d = Dynamic(points.dim());
    for i in 1..points.len() {
        let arc = Arc::between(d, points.get(i - 1), points.get(i));
        if arc.theta < REPEATED_POINT_RAD {
            return Err(SphereError::RepeatedPoint {
                index: i,
                angle_rad: arc.theta,
            });
        }
        if arc.is_near_antipodal() {
            return Err(SphereError::Antipodal {
                index: i,
                angle_rad: arc.theta,
            });
        }
    }
    Ok(())
}

/// Interior joints per parallel work item in the solver's passes. Work items are fixed ranges
/// combined in order, so results do not depend on the number of threads.
const JOINT_CHUNK: usize = 1024;

/// Residual summary over the interior joints: `Σ θ_j^2` (the line-search merit) and the
/// largest `θ_j` (the stopping criterion), radians.
#[derive(Clone, Copy, Debug)]
struct Residuals {
    sum_sq: f64,
    max_rad: f64,
}

impl Residuals {
    const ZERO: Residuals = Residuals {
        sum_sq: 0.0,
        max_rad: 0.0,
    };

    fn add(&mut self, e: f64) {
        self.sum_sq += e * e;
        if e.is_nan() || e > self.max_rad {
            self.max_rad = if e.is_nan() { f64::INFINITY } else { e };
        }
    }

    fn merge(mut self, o: Residuals) -> Residuals {
        self.sum_sq += o.sum_sq;
        self.max_rad = self.max_rad.max(o.max_rad);
        if self.sum_sq.is_nan() {
            self.sum_sq = f64::INFINITY;
        }
        self
    }
}

fn residuals<D: Dim>(d: D, q: &PointSet, fr: &Fractions, aux: &[f64]) -> Residuals {
    let (dim, n) = (d.get(), q.len() - 1);
    let chunks = (n - 1).div_ceil(JOINT_CHUNK);
    let parts: Vec<Residuals> = (0..chunks)
        .into_par_iter()
        .map(|c| {
            let (mut a, mut b, mut f) = (vec![0.0; dim], vec![0.0; dim], vec![0.0; dim]);
            let mut r = Residuals::ZERO;
            for j in 1 + c * JOINT_CHUNK..(1 + (c + 1) * JOINT_CHUNK).min(n) {
                eval_joint(d, aux, fr, j, &mut a, &mut b, &mut f);
                r.add(angle(d, &f, q.get(j)));
            }
            r
        })
        .collect();
    parts.into_iter().fold(Residuals::ZERO, Residuals::merge)
}

/// Runs `solver` from `d_j = q_j` (the paper's step 1) until every interior joint is within
/// [`SOLVER_TARGET_RAD`], the residual stops improving, or `max_iterations`; returns the best
/// iterate (flat) and the number of steps taken.
fn solve<D: Dim>(
    d: D,
    q: &PointSet,
    fr: &Fractions,
    solver: BetaSolver,
    max_iterations: usize,
) -> (Vec<f64>, usize) {
    let mut aux = q.as_flat().to_vec();
    if q.len() < 3 {
        return (aux, 0);
    }
    // Steps without a relative improvement of 1e-6 in the largest residual before giving up:
    // Newton improves every step until the rounding floor; eq. 19 can creep or dither.
    let patience = match solver {
        BetaSolver::Newton => 2,
        BetaSolver::Jacobi => 50,
    };
    let mut current = residuals(d, q, fr, &aux);
    let mut best = aux.clone();
    let mut best_max = current.max_rad;
    let mut since_best = 0;
    let mut iterations = 0;
    let mut newton = None;
    while iterations < max_iterations && best_max > SOLVER_TARGET_RAD && !super::cancel::cancelled()
    {
        iterations += 1;
        match solver {
            BetaSolver::Newton => {
                let work = newton.get_or_insert_with(|| NewtonWork::new(d.get(), q.len()));
                match newton_step(d, q, fr, &mut aux, work, current) {
                    Some(r) => current = r,
                    None => break,
                }
            }
            BetaSolver::Jacobi => {
                jacobi_step(d, q, fr, &mut aux);
                current = residuals(d, q, fr, &aux);
            }
        }
        if current.max_rad < best_max * (1.0 - 1e-6) {
            best.copy_from_slice(&aux);
            best_max = current.max_rad;
            since_best = 0;
        } else {
            since_best += 1;
            if since_best >= patience || !current.sum_sq.is_finite() {
                break;
            }
        }
    }
    (best, iterations)
}

/// One sweep of the paper's eq. 19: `d_j = normalize((q_j - a_j d_(j-1) - c_j d_(j+1)) /
/// lambda_j)`, the coefficients of eq. 18 taken from the previous iterate (divided through by
/// sin psi_j, which the SLERP weights already include). A vertex whose update is not finite
/// keeps its value (the residual check reports the failure).
fn jacobi_step<D: Dim>(d: D, q: &PointSet, fr: &Fractions, aux: &mut [f64]) {
    let (dim, n) = (d.get(), q.len() - 1);
    let (mut a, mut b, mut f) = (vec![0.0; dim], vec![0.0; dim], vec![0.0; dim]);
    let old = aux.to_vec();
    let mut new = vec![0.0; dim];
    for j in 1..n {
        let e = eval_joint(d, &old, fr, j, &mut a, &mut b, &mut f);
        let (cm, cj, cp) = e.coefficients();
        let qj = q.get(j);
        for c in 0..dim {
            new[c] = (qj[c] - cm * old[(j - 1) * dim + c] - cp * old[(j + 1) * dim + c]) / cj;
        }
        if normalize(d, &mut new) > 0.0 && new.iter().all(|x| x.is_finite()) {
            aux[j * dim..(j + 1) * dim].copy_from_slice(&new);
        }
    }
}

/// `w'(theta) / sin(theta)` for the SLERP weight `w = sin(t theta) / sin(theta)`: the factor
/// that turns a change of the arc angle into a change of the point. Series below 1e-2 rad
/// (where the closed form cancels), error O(theta^4) < 1e-8 relative.
#[inline(always)]
fn weight_rate(theta: f64, sin_theta: f64, cos_theta: f64, t: f64) -> f64 {
    if theta < 1e-2 {
        let t2 = t * t;
        t * (1.0 - t2) / 3.0 + t * (t2 - 1.0) * (t2 - 4.0) / 30.0 * theta * theta
    } else {
        let (s, c) = (t * theta).sin_cos();
        (t * c * sin_theta - s * cos_theta) / (sin_theta * sin_theta * sin_theta)
    }
}

/// Jacobians of `s = G[a, b](t) = w0 a + w1 b` with respect to `a` and `b` (for tangent
/// perturbations): `ds = w0 da + w1 db - g (b . da + a . db)`, `g = (w0' a + w1' b) / sin
/// theta`, written as dense `dim x dim` row-major matrices.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn slerp_jacobians<D: Dim>(
    d: D,
    a: &[f64],
    b: &[f64],
    arc: &Arc,
    w: (f64, f64),
    t: f64,
    g: &mut [f64],
    ja: &mut [f64],
    jb: &mut [f64],
) {
    let dim = d.get();
    let h0 = weight_rate(arc.theta, arc.sin_theta, arc.cos_theta, 1.0 - t);
    let h1 = weight_rate(arc.theta, arc.sin_theta, arc.cos_theta, t);
    for c in 0..dim {
        g[c] = h0 * a[c] + h1 * b[c];
    }
    for r in 0..dim {
        for c in 0..dim {
            let id = if r == c { 1.0 } else { 0.0 };
            ja[r * dim + c] = w.0 * id - g[r] * b[c];
            jb[r * dim + c] = w.1 * id - g[r] * a[c];
        }
    }
}

/// `out = x y` for `dim x dim` row-major matrices.
#[inline(always)]
fn matmul<D: Dim>(d: D, x: &[f64], y: &[f64], out: &mut [f64]) {
    let dim = d.get();
    for r in 0..dim {
        for c in 0..dim {
            let mut s = 0.0;
            for k in 0..dim {
                s += x[r * dim + k] * y[k * dim + c];
            }
            out[r * dim + c] = s;
        }
    }
}

/// `m <- m (I - u u^T)`: restricts a Jacobian to the tangent space at unit vector `u`.
#[inline(always)]
fn project_columns<D: Dim>(d: D, m: &mut [f64], u: &[f64]) {
    let dim = d.get();
    for r in 0..dim {
        let mut mu = 0.0;
        for k in 0..dim {
            mu += m[r * dim + k] * u[k];
        }
        for c in 0..dim {
            m[r * dim + c] -= mu * u[c];
        }
    }
}

/// Buffers reused across Newton steps.
struct NewtonWork {
    band: BandLu,
    trial: Vec<f64>,
}

impl NewtonWork {
    fn new(dim: usize, points: usize) -> NewtonWork {
        NewtonWork {
            band: BandLu::new((points - 2) * dim, 2 * dim - 1, 2 * dim - 1),
            trial: vec![0.0; points * dim],
        }
    }
}

/// Per-thread scratch for assembling Newton rows: 9 `dim x dim` matrices, 7 vectors.
struct RowScratch {
    mats: Vec<f64>,
    vecs: Vec<f64>,
}

/// One Newton step on `F_j(d) = q_j`, j = 1..n-1, unknowns `d_1..d_(n-1)`.
///
/// Row j: `L v_(j-1) + D v_j + U v_(j+1) = log_(F_j)(q_j)` with the chain-rule Jacobians of
/// the three SLERPs of eqs. 15–17, each column block projected onto the tangent space at its
/// `d`. The equations are tangent at `F_j`; adding `F_j d_j^T` to `D` makes the system square
/// and forces `v_j . d_j = 0`. The banded system (half-bandwidth `2 dim - 1`) is solved by LU
/// with partial pivoting, then `d_j <- normalize(d_j + s v_j)` with `s` halved until `Σ θ_j^2`
/// decreases. Returns `None` when no step decreases it (the rounding floor, or no solution).
fn newton_step<D: Dim>(
    d: D,
    q: &PointSet,
    fr: &Fractions,
    aux: &mut [f64],
    work: &mut NewtonWork,
    current: Residuals,
) -> Option<Residuals> {
    let (dim, n) = (d.get(), q.len() - 1);
    let (w, kl) = (work.band.width, work.band.kl);
    let aux_ro: &[f64] = aux;
    work.band
        .a
        .par_chunks_mut(dim * w * JOINT_CHUNK)
        .zip(work.band.rhs.par_chunks_mut(dim * JOINT_CHUNK))
        .enumerate()
        .for_each(|(c, (rows, rhs))| {
            let mut s = RowScratch {
                mats: vec![0.0; 9 * dim * dim],
                vecs: vec![0.0; 7 * dim],
            };
            rows.iter_mut().for_each(|x| *x = 0.0);
            for (k, (rows, rhs)) in rows
                .chunks_exact_mut(dim * w)
                .zip(rhs.chunks_exact_mut(dim))
                .enumerate()
            {
                let j = 1 + c * JOINT_CHUNK + k;
                assemble_row(d, q, fr, aux_ro, j, n, (w, kl), rows, rhs, &mut s);
            }
        });
    if !work.band.solve() {
        return None;
    }
    let step = &work.band.rhs;
    let mut s = 1.0;
    // 30 halvings shrink the step to 1e-9 of Newton's: beyond that no decrease is meaningful.
    for _ in 0..30 {
        work.trial.copy_from_slice(aux);
        for j in 1..n {
            let t = &mut work.trial[j * dim..(j + 1) * dim];
            for c in 0..dim {
                t[c] += s * step[(j - 1) * dim + c];
            }
            normalize(d, t);
        }
        let r = residuals(d, q, fr, &work.trial);
        if r.sum_sq < current.sum_sq {
            aux.copy_from_slice(&work.trial);
            return Some(r);
        }
        s *= 0.5;
    }
    None
}

/// Writes Newton row block j (`dim` rows of the band, local storage) and its right-hand side.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn assemble_row<D: Dim>(
    d: D,
    q: &PointSet,
    fr: &Fractions,
    aux: &[f64],
    j: usize,
    n: usize,
    (w, kl): (usize, usize),
    rows: &mut [f64],
    rhs: &mut [f64],
    s: &mut RowScratch,
) {
    let dim = d.get();
    let dd = dim * dim;
    let (ja_m, rest) = s.mats.split_at_mut(dd);
    let (ja_j, rest) = rest.split_at_mut(dd);
    let (jb_j, rest) = rest.split_at_mut(dd);
    let (jb_p, rest) = rest.split_at_mut(dd);
    let (jf_a, rest) = rest.split_at_mut(dd);
    let (jf_b, rest) = rest.split_at_mut(dd);
    let (lo, rest) = rest.split_at_mut(dd);
    let (di, rest) = rest.split_at_mut(dd);
    let (up, _) = rest.split_at_mut(dd);
    let (a, rest) = s.vecs.split_at_mut(dim);
    let (b, rest) = rest.split_at_mut(dim);
    let (f, rest) = rest.split_at_mut(dim);
    let (ga, rest) = rest.split_at_mut(dim);
    let (gb, rest) = rest.split_at_mut(dim);
    let (gf, _) = rest.split_at_mut(dim);
    let e = eval_joint(d, aux, fr, j, a, b, f);
    let (dm, dj, dp) = (
        &aux[(j - 1) * dim..j * dim],
        &aux[j * dim..(j + 1) * dim],
        &aux[(j + 1) * dim..(j + 2) * dim],
    );
    slerp_jacobians(d, dm, dj, &e.arc_a, e.wa, fr.second[j - 1], ga, ja_m, ja_j);
    slerp_jacobians(d, dj, dp, &e.arc_b, e.wb, fr.first[j], gb, jb_j, jb_p);
    slerp_jacobians(d, a, b, &e.arc_f, e.wf, fr.junction[j], gf, jf_a, jf_b);
    matmul(d, jf_a, ja_m, lo);
    project_columns(d, lo, dm);
    // D = (JF_A JA_j + JF_B JB_j) P_j + F d_j^T; `up` holds JF_B JB_j for a moment.
    matmul(d, jf_a, ja_j, di);
    matmul(d, jf_b, jb_j, up);
    for k in 0..dd {
        di[k] += up[k];
    }
    project_columns(d, di, dj);
    for r in 0..dim {
        for c in 0..dim {
            di[r * dim + c] += f[r] * dj[c];
        }
    }
    matmul(d, jf_b, jb_p, up);
    project_columns(d, up, dp);
    log_into(d, f, q.get(j), rhs);
    // Row r of this block is band row (j-1) dim + r; column offset `off` from the diagonal
    // is stored at r w + kl + off.
    for r in 0..dim {
        let row = &mut rows[r * w..(r + 1) * w];
        for c in 0..dim {
            if j > 1 {
                row[kl + c - r - dim] = lo[r * dim + c];
            }
            row[kl + c - r] = di[r * dim + c];
            if j + 1 < n {
                row[kl + c - r + dim] = up[r * dim + c];
            }
        }
    }
}

/// A banded matrix with `kl` sub- and `ku` super-diagonals and its right-hand side, solved in
/// place by Gaussian elimination with partial pivoting (LAPACK's `gbsv` scheme: pivoting
/// widens the upper band to `kl + ku`). Row `r` stores columns `r - kl ..= r + ku + kl`.
struct BandLu {
    n: usize,
    kl: usize,
    ku: usize,
    width: usize,
    a: Vec<f64>,
    rhs: Vec<f64>,
}

impl BandLu {
    fn new(n: usize, kl: usize, ku: usize) -> BandLu {
        let width = 2 * kl + ku + 1;
        BandLu {
            n,
            kl,
            ku,
            width,
            a: vec![0.0; n * width],
            rhs: vec![0.0; n],
        }
    }

    /// Entry (r, c), |c - r| within the band.
    #[cfg(test)]
    fn at(&mut self, r: usize, c: usize) -> &mut f64 {
        let i = r * self.width + c + self.kl - r;
        &mut self.a[i]
    }

    /// Solves in place (`rhs` becomes the solution); false if a pivot is zero or not finite.
    fn solve(&mut self) -> bool {
        let (n, kl, ku, w) = (self.n, self.kl, self.ku, self.width);
        let span = kl + ku + 1;
        for k in 0..n {
            let last = (k + kl).min(n - 1);
            let len = (k + kl + ku).min(n - 1) + 1 - k;
            let (mut p, mut best) = (k, self.a[k * w + kl].abs());
            for r in k + 1..=last {
                let v = self.a[r * w + k + kl - r].abs();
                if v > best {
                    (p, best) = (r, v);
                }
            }
            if !(best > 0.0 && best.is_finite()) {
                return false;
            }
            if p != k {
                let (lo, hi) = self.a.split_at_mut(p * w);
                let (rk, rp) = (k * w + kl, k + kl - p);
                lo[rk..rk + len].swap_with_slice(&mut hi[rp..rp + len]);
                self.rhs.swap(k, p);
            }
            let (head, tail) = self.a.split_at_mut((k + 1) * w);
            let row_k = &head[k * w + kl..k * w + kl + span];
            let (pivot, rhs_k) = (row_k[0], self.rhs[k]);
            for r in k + 1..=last {
                let start = (r - k - 1) * w + k + kl - r;
                let row_r = &mut tail[start..start + span];
                let m = row_r[0] / pivot;
                if m == 0.0 {
                    continue;
                }
                row_r[0] = 0.0;
                for (x, y) in row_r[1..len].iter_mut().zip(&row_k[1..len]) {
                    *x -= m * y;
                }
                self.rhs[r] -= m * rhs_k;
            }
        }
        for k in (0..n).rev() {
            let len = (k + kl + ku).min(n - 1) + 1 - k;
            let row_k = &self.a[k * w + kl..k * w + kl + len];
            let mut s = self.rhs[k];
            for (u, x) in row_k[1..].iter().zip(&self.rhs[k + 1..k + len]) {
                s -= u * x;
            }
            self.rhs[k] = s / row_k[0];
        }
        self.rhs.iter().all(|x| x.is_finite())
    }
}

// ---------------------------------------------------------------------------------------------
// Documents

/// A Beta-spline as JSON: `{"type": "beta", "beta1": [...], "beta2": [...], "segments":
/// [[q0, q1, q2, q3], ...]}`, the cubic spherical Bézier control points (unit vectors) of each
/// segment; segment i spans parameter `[i, i + 1]`, and `q0` of segment i repeats `q3` of
/// segment i - 1. `beta1`/`beta2` hold one value per point (segments + 1); evaluation uses only
/// the segments, the shape parameters record how they were made.
///
/// Deserialising validates ([`BetaDocument::from_json`]); errors carry a JSON pointer such as
/// `/segments/2/1` or `/beta1/3`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "serde_json::Value")]
pub struct BetaDocument {
    /// Always `"beta"`.
    #[serde(rename = "type")]
    pub kind: String,
    /// `beta1` at every point.
    pub beta1: Vec<f64>,
    /// `beta2` at every point.
    pub beta2: Vec<f64>,
    /// Four control points per segment.
    pub segments: Vec<[Vec<f64>; 4]>,
}

impl From<&SphericalBetaSpline> for BetaDocument {
    fn from(s: &SphericalBetaSpline) -> Self {
        let segments = (0..s.segment_count())
            .map(|i| std::array::from_fn(|k| s.control.get(3 * i + k).to_vec()))
            .collect();
        BetaDocument {
            kind: "beta".to_string(),
            beta1: s.beta1.clone(),
            beta2: s.beta2.clone(),
            segments,
        }
    }
}

impl TryFrom<Value> for BetaDocument {
    type Error = InputError;
    fn try_from(v: Value) -> Result<Self, InputError> {
        BetaDocument::from_json(&v)
    }
}

impl BetaDocument {
    /// Parses and validates a Beta-spline document.
    ///
    /// # Errors
    /// An [`InputError`] whose pointer names the field and index at fault.
    pub fn from_json(v: &Value) -> Result<BetaDocument, InputError> {
        let doc = parse_document(v, "")?;
        doc.validate_at("")?;
        Ok(doc)
    }

    /// Validates the document and builds the curve.
    ///
    /// # Errors
    /// An [`InputError`] whose pointer (relative to the document) names the field and index.
    pub fn to_spline(&self) -> Result<SphericalBetaSpline, InputError> {
        self.validate_at("")
    }

    fn validate_at(&self, base: &str) -> Result<SphericalBetaSpline, InputError> {
        if self.kind != "beta" {
            return Err(InputError::at(
                format!("{base}/type"),
                format!("unknown curve type {:?} (expected \"beta\")", self.kind),
            ));
        }
        let n = self.segments.len();
        if n == 0 {
            return Err(InputError::at(
                format!("{base}/segments"),
                "a Beta-spline needs at least one segment",
            ));
        }
        let rows: Vec<&[f64]> = self
            .segments
            .iter()
            .flat_map(|s| s.iter().map(Vec::as_slice))
            .collect();
        let all = PointSet::try_from_rows(&rows).map_err(|e| {
            let p = pointer_for("", &e);
            // Flat row index 4 s + k -> /segments/s/k.
            let mut parts = p.trim_start_matches('/').splitn(2, '/');
            let row: usize = parts.next().and_then(|x| x.parse().ok()).unwrap_or(0);
            let rest = parts.next().map(|c| format!("/{c}")).unwrap_or_default();
            InputError::at(
                format!("{base}/segments/{}/{}{rest}", row / 4, row % 4),
                e.to_string(),
            )
        })?;
        let (dim, d) = (all.dim(), Dynamic(all.dim()));
        let mut control = Vec::with_capacity((3 * n + 1) * dim);
        for s in 0..n {
            if s > 0 {
                let gap = angle(d, all.get(4 * s), all.get(4 * s - 1));
                if gap.is_nan() || gap > JOINT_MATCH_RAD {
                    return Err(InputError::at(
                        format!("{base}/segments/{s}/0"),
                        format!(
                            "must equal the last control point of segment {} (the curve is continuous); they are {gap} rad apart",
                            s - 1
                        ),
                    ));
                }
            } else {
                control.extend_from_slice(all.get(0));
            }
            for k in 1..4 {
                control.extend_from_slice(all.get(4 * s + k));
            }
        }
        let control = PointSet::from_flat_unchecked(dim, control);
        if let Err(e) = control.check_no_antipodal_neighbours() {
            if let SphereError::Antipodal { index, .. } = e {
                let s = (index - 1) / 3;
                return Err(InputError::at(
                    format!("{base}/segments/{s}/{}", index - 3 * s),
                    e.to_string(),
                ));
            }
            return Err(InputError::at(format!("{base}/segments"), e.to_string()));
        }
        let (beta1, beta2) = match expand_shape_parameters(&self.beta1, &self.beta2, n + 1) {
            Ok(b) if self.beta1.len() == n + 1 && self.beta2.len() == n + 1 => b,
            Ok(_) => {
                let (field, got) = if self.beta1.len() != n + 1 {
                    ("beta1", self.beta1.len())
                } else {
                    ("beta2", self.beta2.len())
                };
                return Err(InputError::at(
                    format!("{base}/{field}"),
                    format!(
                        "expected {} values (one per point: segments + 1), got {got}",
                        n + 1
                    ),
                ));
            }
            Err(e) => {
                let pointer = match &e {
                    SphereError::InvalidShapeParameter { field, index, .. } => {
                        format!("{base}/{field}/{index}")
                    }
                    SphereError::ShapeParameterCount { field, .. } => format!("{base}/{field}"),
                    _ => base.to_string(),
                };
                return Err(InputError::at(pointer, e.to_string()));
            }
        };
        Ok(SphericalBetaSpline::from_parts(beta1, beta2, control))
    }
}

/// Reads the JSON shape of a Beta-spline document (types and counts, pointers from `base`).
fn parse_document(v: &Value, base: &str) -> Result<BetaDocument, InputError> {
    let map = v.as_object().ok_or_else(|| {
        InputError::at(
            base,
            "expected a Beta-spline document {\"type\": \"beta\", \"beta1\", \"beta2\", \"segments\"}",
        )
    })?;
    if let Some(k) = map
        .keys()
        .find(|k| !matches!(k.as_str(), "type" | "beta1" | "beta2" | "segments"))
    {
        return Err(InputError::at(
            format!("{base}/{k}"),
            "unknown field: a Beta-spline document has \"type\", \"beta1\", \"beta2\" and \"segments\"",
        ));
    }
    let kind = match map.get("type") {
        None => "beta".to_string(),
        Some(Value::String(s)) => s.clone(),
        Some(_) => {
            return Err(InputError::at(
                format!("{base}/type"),
                "expected the string \"beta\"",
            ))
        }
    };
    let field = |name: &str| {
        map.get(name).ok_or_else(|| {
            InputError::at(
                base,
                format!("missing field \"{name}\" of the Beta-spline document"),
            )
        })
    };
    let beta1 = number_list(field("beta1")?, &format!("{base}/beta1"))?;
    let beta2 = number_list(field("beta2")?, &format!("{base}/beta2"))?;
    let seg_base = format!("{base}/segments");
    let segs = field("segments")?
        .as_array()
        .ok_or_else(|| InputError::at(&seg_base, "expected an array of segments"))?;
    let mut segments = Vec::with_capacity(segs.len());
    for (i, s) in segs.iter().enumerate() {
        let rows = number_rows(s, &format!("{seg_base}/{i}"))?;
        let got = rows.len();
        let seg: [Vec<f64>; 4] = rows.try_into().map_err(|_| {
            InputError::at(
                format!("{seg_base}/{i}"),
                format!("expected 4 control points (a cubic segment), got {got}"),
            )
        })?;
        segments.push(seg);
    }
    Ok(BetaDocument {
        kind,
        beta1,
        beta2,
        segments,
    })
}

/// Reads a Beta-spline document, or an `interpolate` result holding one under `"curve"`.
///
/// # Errors
/// An [`InputError`] pointing at the offending value (e.g. `/curve/segments/1/2`).
pub fn beta_from_json(v: &Value) -> Result<SphericalBetaSpline, InputError> {
    let (doc_v, base) = match v.get("curve") {
        Some(c) => (c, "/curve"),
        None => (v, ""),
    };
    parse_document(doc_v, base)?.validate_at(base)
}

/// The result of `sphere interpolate` and `/v1/interpolate`: `{"curve": <Beta-spline
/// document>, "residual_rad": r, "iterations": k}`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct InterpolationDocument {
    /// The interpolating curve.
    pub curve: BetaDocument,
    /// Largest angle between the curve at parameter j and point j, radians.
    pub residual_rad: f64,
    /// Solver steps taken.
    pub iterations: usize,
}

impl From<&BetaInterpolation> for InterpolationDocument {
    fn from(r: &BetaInterpolation) -> Self {
        InterpolationDocument {
            curve: BetaDocument::from(&r.spline),
            residual_rad: r.residual_rad,
            iterations: r.iterations,
        }
    }
}

/// Either curve a document can hold, so output code (sampling, GeoJSON, `evaluate`) takes one
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
}

/// Reads any curve document: a spline document, a `sphere fit` result (`"spline"`), a
/// Beta-spline document, or a `sphere interpolate` result (`"curve"`). A document is a
/// Beta-spline when its `"type"` is `"beta"` or it has `"segments"`.
///
/// # Errors
/// An [`InputError`] pointing at the offending value.
pub fn curve_from_json(v: &Value) -> Result<AnyCurve, InputError> {
    let (inner, base) = if let Some(c) = v.get("curve") {
        (c, "/curve")
    } else if v.get("spline").is_some() {
        return spline_from_json(v).map(AnyCurve::BSpline);
    } else {
        (v, "")
    };
    let is_beta = inner.get("type").and_then(Value::as_str) == Some("beta")
        || inner.get("segments").is_some();
    if is_beta {
        return beta_from_json(v).map(AnyCurve::Beta);
    }
    spline_from_json(inner)
        .map(AnyCurve::BSpline)
        .map_err(|e| InputError::at(format!("{base}{}", e.pointer), e.message))
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    fn unit(v: [f64; 3]) -> Vec<f64> {
        let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        v.iter().map(|x| x / n).collect()
    }

    fn example1() -> PointSet {
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
    fn example2() -> PointSet {
        PointSet::try_from_rows(&[
            unit([1.0, 0.0, 0.0]),
            unit([0.6852, -0.5424, 0.4861]),
            unit([0.7071, 0.0, 0.7071]),
            unit([0.0, 1.0, 0.0]),
        ])
        .unwrap()
    }

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
    fn every_solver_interpolates_the_paper_examples() {
        for points in [example1(), example2()] {
            for solver in [BetaSolver::Newton, BetaSolver::Jacobi] {
                let opts = InterpolationOptions::default().with_solver(solver);
                let r = interpolate(&points, &opts).unwrap();
                assert!(r.residual_rad <= 1e-14, "{solver:?}: {}", r.residual_rad);
                for j in 0..points.len() {
                    let p = r.spline.evaluate(j as f64);
                    assert!(angle(Dynamic(3), &p, points.get(j)) <= 1e-14);
                }
            }
        }
    }

    #[test]
    fn newton_solves_where_the_papers_iteration_stalls() {
        // Example 2 with beta1 = 0.1 at point 1 (METHOD.md: eq. 19 is slow or stalls there).
        let opts = InterpolationOptions::default().with_beta1_per_point(vec![1.0, 0.1, 1.0, 1.0]);
        let newton = interpolate(&example2(), &opts).unwrap();
        assert!(newton.residual_rad <= 1e-14);
        assert!(newton.iterations <= 20, "{}", newton.iterations);
    }

    #[test]
    fn construction_matches_eqs_4_to_6() {
        let aux = example1();
        let s = SphericalBetaSpline::try_from_auxiliary(&aux, &[1.0], &[0.0]).unwrap();
        assert_eq!(s.segment_count(), 3);
        let slerp = crate::sphere::point::slerp;
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

    fn angle_between(a: &[f64], b: &[f64]) -> f64 {
        crate::sphere::point::angle_between(a, b)
    }

    #[test]
    fn band_lu_pivots() {
        // [[0, 1, 0], [1, 0, 1], [0, 1, 1]] x = [1, 2, 3] -> x = [0, 1, 2]; needs a row swap.
        let mut m = BandLu::new(3, 1, 1);
        for (r, c, v) in [
            (0, 1, 1.0),
            (1, 0, 1.0),
            (1, 2, 1.0),
            (2, 1, 1.0),
            (2, 2, 1.0),
        ] {
            *m.at(r, c) = v;
        }
        m.rhs.copy_from_slice(&[1.0, 2.0, 3.0]);
        assert!(m.solve());
        for (x, want) in m.rhs.iter().zip([0.0, 1.0, 2.0]) {
            assert_relative_eq!(*x, want, epsilon = 1e-15);
        }
        let mut singular = BandLu::new(2, 1, 1);
        assert!(!singular.solve());
    }

    #[test]
    fn weight_rate_series_meets_closed_form() {
        for t in [0.1, 1.0 / 3.0, 0.5, 0.9] {
            let th: f64 = 1e-2;
            let (s, c) = th.sin_cos();
            let closed = (t * (t * th).cos() * s - (t * th).sin() * c) / (s * s * s);
            let series = weight_rate(th * 0.999_999, s, c, t);
            assert_relative_eq!(closed, series, max_relative = 1e-7);
        }
    }

    #[test]
    fn document_round_trips_and_names_bad_values() {
        let r = interpolate(&example1(), &InterpolationOptions::default()).unwrap();
        let doc = BetaDocument::from(&r.spline);
        let text = serde_json::to_string(&doc).unwrap();
        // serde_json's default float parser may be 1 ulp off, so compare geometrically.
        let back: BetaDocument = serde_json::from_str(&text).unwrap();
        let again = back.to_spline().unwrap();
        assert_eq!(again.beta1(), r.spline.beta1());
        assert_eq!(again.beta2(), r.spline.beta2());
        let (a, b) = (again.control_points(), r.spline.control_points());
        assert_eq!(a.len(), b.len());
        for i in 0..a.len() {
            assert!(angle_between(a.get(i), b.get(i)) < 1e-15);
        }

        let mut v: Value = serde_json::from_str(&text).unwrap();
        v["segments"][1][2] = serde_json::json!([0.0, 2.0, 0.0]);
        assert_eq!(
            BetaDocument::from_json(&v).unwrap_err().pointer,
            "/segments/1/2"
        );
        let mut v: Value = serde_json::from_str(&text).unwrap();
        v["segments"][2][0] = serde_json::json!([0.0, 1.0, 0.0]);
        assert_eq!(
            BetaDocument::from_json(&v).unwrap_err().pointer,
            "/segments/2/0"
        );
        let mut v: Value = serde_json::from_str(&text).unwrap();
        v["beta1"][3] = serde_json::json!(-1.0);
        assert_eq!(BetaDocument::from_json(&v).unwrap_err().pointer, "/beta1/3");
        let mut v: Value = serde_json::from_str(&text).unwrap();
        v["beta2"] = serde_json::json!([0.0]);
        assert_eq!(BetaDocument::from_json(&v).unwrap_err().pointer, "/beta2");
        let mut v: Value = serde_json::from_str(&text).unwrap();
        v["segments"][0] = serde_json::json!([[1, 0, 0], [0, 1, 0]]);
        assert_eq!(
            BetaDocument::from_json(&v).unwrap_err().pointer,
            "/segments/0"
        );
        let mut v: Value = serde_json::from_str(&text).unwrap();
        v["segments"][0][1][2] = serde_json::json!("x");
        assert_eq!(
            BetaDocument::from_json(&v).unwrap_err().pointer,
            "/segments/0/1/2"
        );
        let e = serde_json::from_value::<BetaDocument>(
            serde_json::json!({"type": "beta", "beta1": [1], "beta2": [0], "segments": []}),
        )
        .unwrap_err();
        assert!(e.to_string().contains("/segments"), "{e}");
    }

    #[test]
    fn curve_from_json_accepts_every_curve_document() {
        let r = interpolate(&example2(), &InterpolationOptions::default()).unwrap();
        let beta = serde_json::to_value(BetaDocument::from(&r.spline)).unwrap();
        let wrapped = serde_json::to_value(InterpolationDocument::from(&r)).unwrap();
        assert!(matches!(curve_from_json(&beta), Ok(AnyCurve::Beta(_))));
        assert!(matches!(curve_from_json(&wrapped), Ok(AnyCurve::Beta(_))));
        let spline = serde_json::json!({"degree": 1, "knots": [0, 0, 1, 1], "control_points": [[1, 0, 0], [0, 1, 0]]});
        assert!(matches!(curve_from_json(&spline), Ok(AnyCurve::BSpline(_))));
        let fit = serde_json::json!({ "spline": spline });
        assert!(matches!(curve_from_json(&fit), Ok(AnyCurve::BSpline(_))));
        let bad = serde_json::json!({"curve": {"degree": 1, "knots": [0, 0, 1, 1], "control_points": [[1, 0, 0], [0, 3, 0]]}});
        assert_eq!(
            curve_from_json(&bad).unwrap_err().pointer,
            "/curve/control_points/1"
        );
        let mut w = wrapped.clone();
        w["curve"]["segments"][0][3] = serde_json::json!([0, 0, 0]);
        assert_eq!(
            curve_from_json(&w).unwrap_err().pointer,
            "/curve/segments/0/3"
        );
    }

    #[test]
    fn interpolates_on_the_circle_s1() {
        let rows: Vec<[f64; 2]> = [0.0_f64, 0.4, 1.1, 1.5, 2.6]
            .iter()
            .map(|a| [a.cos(), a.sin()])
            .collect();
        let points = PointSet::try_from_rows(&rows).unwrap();
        let r = interpolate(&points, &InterpolationOptions::default()).unwrap();
        assert!(r.residual_rad <= 1e-14);
        // On S^1 every curve runs along the circle: the points stay unit and in order.
        let (_, pts) = r.spline.sample(41);
        let mut last = -1.0;
        for p in pts.iter() {
            assert!((p[0].hypot(p[1]) - 1.0).abs() < 1e-14);
            let a = p[1].atan2(p[0]);
            assert!(a >= last - 1e-12, "{a} after {last}");
            last = a;
        }
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
