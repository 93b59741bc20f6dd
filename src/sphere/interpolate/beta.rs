//! Interpolation with the cubic spherical Beta-spline (Yang, Wang, Chen, Sun, He 2021,
//! "Research on the spherical Beta spline curve"; reconstruction in `METHOD.md`): the curve
//! itself is [`crate::sphere::curve::beta`].
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
//! Hot loops are generic over `Dim`, so S^2 runs on `Fixed<3>`.

use crate::sphere::curve::beta::{build_control, eval_joint, Fractions};
use crate::sphere::geometry::point::{angle, log_into, normalize, Arc, Dim, Dynamic, PointSet};
use crate::sphere::linalg::band_lu::BandLu;
use crate::sphere::SphereError;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

pub use crate::sphere::curve::beta::{
    expand_shape_parameters, gamma, SphericalBetaSpline, BETA1_RANGE,
};

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

/// Default iteration limit of [`BetaSolver::Newton`]; it converges in under 10 steps on every
/// input measured, so 50 only matters for inputs it cannot solve.
pub const DEFAULT_NEWTON_ITERATIONS: usize = 50;

/// Default iteration limit of the fixed-point solvers (eq. 19): their rate is about 1/2
/// (Jacobi) or 1/4 (Gauss–Seidel) per iteration at `beta1 = 1`, much slower when `beta1` is far
/// from 1.
pub const DEFAULT_FIXED_POINT_ITERATIONS: usize = 5000;

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

from_names!(BetaSolver, "solver", "newton or jacobi" {
    "newton" => Newton,
    "jacobi" => Jacobi,
});

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
    pub cancel: crate::sphere::cancel::Cancel,
}

impl Default for InterpolationOptions {
    fn default() -> Self {
        InterpolationOptions {
            beta1: vec![1.0],
            beta2: vec![0.0],
            solver: BetaSolver::Newton,
            max_iterations: None,
            tolerance_rad: INTERPOLATION_TOLERANCE_RAD,
            cancel: crate::sphere::cancel::Cancel::inherit(),
        }
    }
}

impl InterpolationOptions {
    /// The same `beta1` at every point.
    pub fn with_beta1(mut self, beta1: f64) -> Self {
        self.beta1 = vec![beta1];
        self
    }
    /// The same `beta2` at every point.
    pub fn with_beta2(mut self, beta2: f64) -> Self {
        self.beta2 = vec![beta2];
        self
    }
    with_fields! {
        /// One `beta1` per point.
        with_beta1_per_point(beta1: Vec<f64>);
        /// One `beta2` per point.
        with_beta2_per_point(beta2: Vec<f64>);
        /// Sets the solver.
        with_solver(solver: BetaSolver);
        /// Sets the iteration limit.
        with_max_iterations(max_iterations: usize) = Some;
        /// Sets the accepted residual in radians.
        with_tolerance_rad(tolerance_rad: f64);
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
    while iterations < max_iterations
        && best_max > SOLVER_TARGET_RAD
        && !crate::sphere::cancel::cancelled()
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

/// One SLERP `G[a, b](t)` of a joint (eqs. 15–17): its end points, their arc, and the weights
/// `w` at fraction `t`.
struct SlerpAt<'a> {
    a: &'a [f64],
    b: &'a [f64],
    arc: &'a Arc,
    w: (f64, f64),
    t: f64,
}

/// Jacobians of `s = G[a, b](t) = w0 a + w1 b` with respect to `a` and `b` (for tangent
/// perturbations): `ds = w0 da + w1 db - g (b . da + a . db)`, `g = (w0' a + w1' b) / sin
/// theta`, written as dense `dim x dim` row-major matrices.
#[inline(always)]
fn slerp_jacobians<D: Dim>(d: D, slerp: SlerpAt, g: &mut [f64], ja: &mut [f64], jb: &mut [f64]) {
    let SlerpAt { a, b, arc, w, t } = slerp;
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
    let system = JointSystem { q, fr, aux };
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
                assemble_row(d, system, j, (w, kl), rows, rhs, &mut s);
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

/// What every row of a Newton step reads: the points interpolated, the fractions of the three
/// SLERPs per joint, and the current auxiliary vertices.
#[derive(Clone, Copy)]
struct JointSystem<'a> {
    q: &'a PointSet,
    fr: &'a Fractions,
    aux: &'a [f64],
}

/// Writes Newton row block j (`dim` rows of the band with width and lower bandwidth `w`, `kl`,
/// local storage) and its right-hand side.
#[inline(always)]
fn assemble_row<D: Dim>(
    d: D,
    system: JointSystem,
    j: usize,
    (w, kl): (usize, usize),
    rows: &mut [f64],
    rhs: &mut [f64],
    s: &mut RowScratch,
) {
    let JointSystem { q, fr, aux } = system;
    let n = q.len() - 1;
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
    let slerp_a = SlerpAt {
        a: dm,
        b: dj,
        arc: &e.arc_a,
        w: e.wa,
        t: fr.second[j - 1],
    };
    slerp_jacobians(d, slerp_a, ga, ja_m, ja_j);
    let slerp_b = SlerpAt {
        a: dj,
        b: dp,
        arc: &e.arc_b,
        w: e.wb,
        t: fr.first[j],
    };
    slerp_jacobians(d, slerp_b, gb, jb_j, jb_p);
    let slerp_f = SlerpAt {
        a,
        b,
        arc: &e.arc_f,
        w: e.wf,
        t: fr.junction[j],
    };
    slerp_jacobians(d, slerp_f, gf, jf_a, jf_b);
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sphere::curve::SphericalCurve;
    use crate::sphere::interpolate::paper_examples::{example1, example2};
    use approx::assert_relative_eq;

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
}
