//! Jupp–Kent unwrapping (P. E. Jupp & J. T. Kent, "Fitting smooth paths to spherical data",
//! Applied Statistics 36(1), 1987, pp. 34–46; the GLS-PIA paper's \[JK18\]).
//!
//! 1. **Unwrap.** Roll the sphere without slipping along a piecewise-geodesic path through
//!    points `c_i` (first the data themselves): the path develops onto a polyline `x_i` in
//!    R^n, the frames at the `c_i` being parallel transports of one frame
//!    (the frame of the first point carried by parallel transport). Each data point goes to `y_i = x_i + F_iᵀ log_{c_i}(p_i)`
//!    (on the first round `y_i = x_i`).
//! 2. **Smooth.** Fit a Euclidean cubic smoothing spline to `(t_i, y_i)`, each coordinate
//!    with the same weight α: minimise `Σ ‖y_i − g(t_i)‖² + α ∫₀¹ ‖g''‖²` (Reinsch's
//!    algorithm, O(points)).
//! 3. **Wrap back.** Roll the sphere along the same path again and carry the plane's points
//!    back: `γ(t) = exp_{c(t)}(F(t)(g(t) − x̄(t)))` with `c(t)` the contact point (the path at
//!    `t`), `x̄(t)` its planar position and `F(t)` the transported frame.
//!
//! Choices the papers leave open, made here:
//! * **Smoothing: generalised cross-validation** by default (Jupp & Kent choose the smoothing
//!   parameter by cross-validation; GCV is its rotation-invariant form, Craven & Wahba 1979),
//!   minimised over `log α` on a grid of 57 values `α = ρ h̄³`, `ρ = 10^-4 … 10^10` (`h̄` the
//!   mean parameter step, which makes ρ scale-free), refined by 40 golden-section steps.
//!   The score pools the n coordinates: `GCV = N · RSS / (N − tr A)²` with N the number of
//!   points and `tr A` computed exactly from the band of the inverse (Hutchinson & de Hoog
//!   1985). A fixed α or a number of equivalent degrees of freedom can be asked instead.
//! * **Iteration.** Jupp & Kent note that the fit improves when the data are unwrapped again
//!   along the fitted path; here the path of round r + 1 is the fitted curve at the data
//!   parameters, and rounds stop when the fitted points move less than 1e-12 rad, after
//!   [`MethodOptions::iterations`] rounds (default 50) or at the time budget — the GLS-PIA
//!   paper's stopping rule ("the same amount of time as our 30 iterations").
//! * The first frame is built from the coordinate axes at the first point; the fit does not depend
//!   on it (rotating the frame rotates the plane).
//! * Parameters must increase strictly (the smoothing spline has one value per abscissa):
//!   repeated points with equal chord-length parameters are refused
//!   ([`CompareError::RepeatedParameter`]).

use crate::sphere::compare::frame::{develop, wrap, Walk};
use crate::sphere::compare::{Clock, CompareError, Fitted, MethodOptions, Smoothing};
use crate::sphere::geometry::point::{angle_between, log_into, Dynamic, PointSet};

/// Rounds of unwrapping when [`MethodOptions::iterations`] is not given.
pub const DEFAULT_ROUNDS: usize = 50;

/// Rounds stop when no fitted point moved more than this (radians).
pub const MOVE_TOLERANCE: f64 = 1e-12;

/// Fits `points` at strictly increasing `params` and samples the curve at `ts`.
pub(crate) fn fit(
    points: &PointSet,
    params: &[f64],
    options: &MethodOptions,
    ts: &[f64],
) -> Result<Fitted, CompareError> {
    if let Some(i) = (1..params.len()).find(|&i| params[i] <= params[i - 1]) {
        return Err(CompareError::RepeatedParameter {
            index: i,
            parameter: params[i],
        });
    }
    let n_pts = points.len();
    if let Smoothing::DegreesOfFreedom(df) = options.smoothing {
        if df > n_pts as f64 {
            return Err(CompareError::InvalidOption {
                option: "smoothing",
                value: df.to_string(),
                rule: format!(
                    "degrees of freedom must be more than 2 and at most the number of points ({n_pts})"
                ),
            });
        }
    }
    let dim = points.dim();
    let n = dim - 1;
    let d = Dynamic(dim);
    let clock = Clock::start(options.time_budget);
    let rounds = options.iterations.unwrap_or(DEFAULT_ROUNDS);
    let mut path = points.clone();
    let mut done = 0;
    let mut converged = false;
    let mut last: Option<(PointSet, Vec<f64>, SmoothingSpline)> = None;
    let mut log = vec![0.0; dim];
    let mut local = vec![0.0; n];
    while done < rounds {
        options.gls_pia.cancel.check()?;
        let x = develop(&path);
        // Unwrapped data: n coordinates per point.
        let mut y = x.clone();
        let mut walk = Walk::new(&path);
        for i in 0..n_pts {
            walk.advance_to(i);
            log_into(d, path.get(i), points.get(i), &mut log);
            walk.frame().coords(&log, &mut local);
            for c in 0..n {
                y[i * n + c] += local[c];
            }
        }
        let spline = SmoothingSpline::fit(params, &y, n, options.smoothing)?;
        let mut next = Vec::with_capacity(n_pts * dim);
        let mut moved: f64 = 0.0;
        let mut walk = Walk::new(&path);
        for i in 0..n_pts {
            walk.advance_to(i);
            let xi = &x[i * n..(i + 1) * n];
            let q = wrap(
                walk.frame(),
                (path.get(i), path.get(i)),
                (xi, xi),
                0.0,
                spline.value(i),
            );
            moved = moved.max(angle_between(&q, path.get(i)));
            next.extend_from_slice(&q);
        }
        let fitted = PointSet::from_flat_unchecked(dim, next);
        done += 1;
        last = Some((std::mem::replace(&mut path, fitted), x, spline));
        if done > 1 && moved < MOVE_TOLERANCE {
            converged = true;
            break;
        }
        if clock.spent() {
            break;
        }
    }
    let Some((rolled, x, spline)) = last else {
        return Err(CompareError::InvalidOption {
            option: "iterations",
            value: "0".into(),
            rule: "use at least 1".into(),
        });
    };
    // The curve is the last round's smoothing spline wrapped along the path it was unrolled
    // from; `path` holds it at the data parameters.
    let mut coords = Vec::with_capacity(ts.len() * dim);
    let mut g = vec![0.0; n];
    let mut walk = Walk::new(&rolled);
    for &t in ts {
        let k = params.partition_point(|&u| u <= t).clamp(1, n_pts - 1) - 1;
        let s = ((t - params[k]) / (params[k + 1] - params[k])).clamp(0.0, 1.0);
        spline.evaluate(t, &mut g);
        walk.advance_to(k);
        let p = wrap(
            walk.frame(),
            (rolled.get(k), rolled.get(k + 1)),
            (&x[k * n..(k + 1) * n], &x[(k + 1) * n..(k + 2) * n]),
            s,
            &g,
        );
        coords.extend_from_slice(&p);
    }
    Ok(Fitted {
        fitted: path,
        samples: PointSet::from_flat_unchecked(dim, coords),
        iterations: done,
        converged,
        free_points: spline.degrees_of_freedom.round() as usize,
    })
}

/// A natural cubic smoothing spline of n-vector values (Green & Silverman 1994, §2.3): the
/// values `g_i` and second derivatives `γ_i` at the abscissae (`γ` zero at both ends).
#[derive(Clone, Debug)]
pub(crate) struct SmoothingSpline {
    t: Vec<f64>,
    cols: usize,
    g: Vec<f64>,
    gamma: Vec<f64>,
    /// The trace of the hat matrix (equivalent degrees of freedom per coordinate).
    pub(crate) degrees_of_freedom: f64,
}

/// The band matrices of Reinsch's algorithm for abscissae `t`: `Q` (n × (n − 2), columns
/// `(a_j, b_j, c_j)` at rows `j, j + 1, j + 2`), `R` ((n − 2) tridiagonal) and `QᵀQ`
/// (pentadiagonal), stored by diagonals.
struct Reinsch {
    qa: Vec<f64>,
    qb: Vec<f64>,
    qc: Vec<f64>,
    r0: Vec<f64>,
    r1: Vec<f64>,
    m0: Vec<f64>,
    m1: Vec<f64>,
    m2: Vec<f64>,
}

impl Reinsch {
    fn new(t: &[f64]) -> Reinsch {
        let n = t.len();
        let m = n - 2;
        let h: Vec<f64> = (0..n - 1).map(|i| t[i + 1] - t[i]).collect();
        let qa: Vec<f64> = (0..m).map(|j| 1.0 / h[j]).collect();
        let qc: Vec<f64> = (0..m).map(|j| 1.0 / h[j + 1]).collect();
        let qb: Vec<f64> = (0..m).map(|j| -qa[j] - qc[j]).collect();
        let r0 = (0..m).map(|j| (h[j] + h[j + 1]) / 3.0).collect();
        let r1 = (0..m)
            .map(|j| if j + 1 < m { h[j + 1] / 6.0 } else { 0.0 })
            .collect();
        let m0 = (0..m)
            .map(|j| qa[j] * qa[j] + qb[j] * qb[j] + qc[j] * qc[j])
            .collect();
        let m1 = (0..m)
            .map(|j| {
                if j + 1 < m {
                    qb[j] * qa[j + 1] + qc[j] * qb[j + 1]
                } else {
                    0.0
                }
            })
            .collect();
        let m2 = (0..m)
            .map(|j| if j + 2 < m { qc[j] * qa[j + 2] } else { 0.0 })
            .collect();
        Reinsch {
            qa,
            qb,
            qc,
            r0,
            r1,
            m0,
            m1,
            m2,
        }
    }
}

/// `L D Lᵀ` of a symmetric pentadiagonal matrix: `d`, and `l1[i] = L(i+1, i)`,
/// `l2[i] = L(i+2, i)`.
struct PentaLdl {
    d: Vec<f64>,
    l1: Vec<f64>,
    l2: Vec<f64>,
}

impl PentaLdl {
    /// Factorises the matrix with diagonals `b0, b1, b2`; `None` when it is not positive
    /// definite.
    fn new(b0: &[f64], b1: &[f64], b2: &[f64]) -> Option<PentaLdl> {
        let m = b0.len();
        let (mut d, mut l1, mut l2) = (vec![0.0; m], vec![0.0; m], vec![0.0; m]);
        for i in 0..m {
            let mut di = b0[i];
            if i >= 1 {
                di -= l1[i - 1] * l1[i - 1] * d[i - 1];
            }
            if i >= 2 {
                di -= l2[i - 2] * l2[i - 2] * d[i - 2];
            }
            if !(di > 0.0 && di.is_finite()) {
                return None;
            }
            d[i] = di;
            let mut e = b1[i];
            if i >= 1 {
                e -= l2[i - 1] * l1[i - 1] * d[i - 1];
            }
            l1[i] = if i + 1 < m { e / di } else { 0.0 };
            l2[i] = if i + 2 < m { b2[i] / di } else { 0.0 };
        }
        Some(PentaLdl { d, l1, l2 })
    }

    /// Solves in place for `cols` right-hand sides stored row-major.
    fn solve(&self, b: &mut [f64], cols: usize) {
        let m = self.d.len();
        for i in 0..m {
            for c in 0..cols {
                let mut v = b[i * cols + c];
                if i >= 1 {
                    v -= self.l1[i - 1] * b[(i - 1) * cols + c];
                }
                if i >= 2 {
                    v -= self.l2[i - 2] * b[(i - 2) * cols + c];
                }
                b[i * cols + c] = v;
            }
        }
        for i in 0..m {
            for c in 0..cols {
                b[i * cols + c] /= self.d[i];
            }
        }
        for i in (0..m).rev() {
            for c in 0..cols {
                let mut v = b[i * cols + c];
                if i + 1 < m {
                    v -= self.l1[i] * b[(i + 1) * cols + c];
                }
                if i + 2 < m {
                    v -= self.l2[i] * b[(i + 2) * cols + c];
                }
                b[i * cols + c] = v;
            }
        }
    }

    /// `tr(B⁻¹ M)` for a symmetric pentadiagonal `M` (diagonals `m0, m1, m2`), from the band
    /// of `S = B⁻¹` (Takahashi's recurrence `S = D⁻¹L⁻¹ + (I − Lᵀ)S`, from the last row up).
    fn trace_inverse_times(&self, m0: &[f64], m1: &[f64], m2: &[f64]) -> f64 {
        let m = self.d.len();
        let (mut s0, mut s1, mut s2) = (vec![0.0; m], vec![0.0; m], vec![0.0; m]);
        let at = |v: &Vec<f64>, i: usize| if i < m { v[i] } else { 0.0 };
        for i in (0..m).rev() {
            let (a, b) = (self.l1[i], self.l2[i]);
            // S(i, i+2) = −a S(i+1, i+2) − b S(i+2, i+2)
            s2[i] = if i + 2 < m {
                -a * at(&s1, i + 1) - b * at(&s0, i + 2)
            } else {
                0.0
            };
            // S(i, i+1) = −a S(i+1, i+1) − b S(i+1, i+2)
            s1[i] = if i + 1 < m {
                -a * at(&s0, i + 1) - b * at(&s1, i + 1)
            } else {
                0.0
            };
            s0[i] = 1.0 / self.d[i] - a * s1[i] - b * s2[i];
        }
        (0..m)
            .map(|i| s0[i] * m0[i] + 2.0 * s1[i] * m1[i] + 2.0 * s2[i] * m2[i])
            .sum()
    }
}

impl SmoothingSpline {
    /// The smoothing spline of `y` (`cols` values per abscissa) at strictly increasing `t`
    /// (at least 3), with α chosen by `smoothing`.
    pub(crate) fn fit(
        t: &[f64],
        y: &[f64],
        cols: usize,
        smoothing: Smoothing,
    ) -> Result<SmoothingSpline, CompareError> {
        let n = t.len();
        if n < 3 {
            return Err(CompareError::Singular {
                method: "jupp-kent",
                reason: format!("a smoothing spline needs at least 3 points, got {n}"),
            });
        }
        let r = Reinsch::new(t);
        let hbar = (t[n - 1] - t[0]) / (n - 1) as f64;
        let scale = hbar * hbar * hbar;
        let alpha = match smoothing {
            Smoothing::Lambda(a) => a,
            Smoothing::Gcv => {
                let score = |lr: f64| {
                    Self::solve(&r, t, y, cols, scale * 10f64.powf(lr))
                        .map(|s| s.gcv(y))
                        .unwrap_or(f64::INFINITY)
                };
                let grid: Vec<f64> = (0..57).map(|k| -4.0 + 0.25 * k as f64).collect();
                let scores: Vec<f64> = grid.iter().map(|&g| score(g)).collect();
                let best = (0..grid.len())
                    .min_by(|&a, &b| scores[a].total_cmp(&scores[b]))
                    .unwrap_or(0);
                let (mut lo, mut hi) = (
                    grid[best.saturating_sub(1)],
                    grid[(best + 1).min(grid.len() - 1)],
                );
                let phi = (5f64.sqrt() - 1.0) / 2.0;
                let (mut x1, mut x2) = (hi - phi * (hi - lo), lo + phi * (hi - lo));
                let (mut f1, mut f2) = (score(x1), score(x2));
                for _ in 0..40 {
                    if f1 <= f2 {
                        hi = x2;
                        x2 = x1;
                        f2 = f1;
                        x1 = hi - phi * (hi - lo);
                        f1 = score(x1);
                    } else {
                        lo = x1;
                        x1 = x2;
                        f1 = f2;
                        x2 = lo + phi * (hi - lo);
                        f2 = score(x2);
                    }
                }
                let lr = 0.5 * (lo + hi);
                scale
                    * 10f64.powf(if score(lr) <= scores[best] {
                        lr
                    } else {
                        grid[best]
                    })
            }
            Smoothing::DegreesOfFreedom(target) => {
                // tr A falls from n (α → 0) to 2 (α → ∞): bisect on log α.
                let df = |lr: f64| {
                    Self::solve(&r, t, y, cols, scale * 10f64.powf(lr))
                        .map(|s| s.degrees_of_freedom)
                        .unwrap_or(f64::NAN)
                };
                let (mut lo, mut hi) = (-12.0, 20.0);
                for _ in 0..80 {
                    let mid = 0.5 * (lo + hi);
                    if df(mid) > target {
                        lo = mid;
                    } else {
                        hi = mid;
                    }
                }
                scale * 10f64.powf(0.5 * (lo + hi))
            }
        };
        Self::solve(&r, t, y, cols, alpha).ok_or_else(|| CompareError::Singular {
            method: "jupp-kent",
            reason: format!("the smoothing system for alpha {alpha} is not positive definite"),
        })
    }

    /// Reinsch's algorithm for one α: `(R + α QᵀQ) γ = Qᵀ y`, `g = y − α Q γ`.
    fn solve(r: &Reinsch, t: &[f64], y: &[f64], cols: usize, alpha: f64) -> Option<Self> {
        let n = t.len();
        let m = n - 2;
        let b0: Vec<f64> = (0..m).map(|j| r.r0[j] + alpha * r.m0[j]).collect();
        let b1: Vec<f64> = (0..m).map(|j| r.r1[j] + alpha * r.m1[j]).collect();
        let b2: Vec<f64> = (0..m).map(|j| alpha * r.m2[j]).collect();
        let ldl = PentaLdl::new(&b0, &b1, &b2)?;
        let mut gam = vec![0.0; m * cols];
        for j in 0..m {
            for c in 0..cols {
                gam[j * cols + c] = r.qa[j] * y[j * cols + c]
                    + r.qb[j] * y[(j + 1) * cols + c]
                    + r.qc[j] * y[(j + 2) * cols + c];
            }
        }
        ldl.solve(&mut gam, cols);
        let mut g = y.to_vec();
        for j in 0..m {
            for c in 0..cols {
                let v = alpha * gam[j * cols + c];
                g[j * cols + c] -= r.qa[j] * v;
                g[(j + 1) * cols + c] -= r.qb[j] * v;
                g[(j + 2) * cols + c] -= r.qc[j] * v;
            }
        }
        let mut gamma = vec![0.0; n * cols];
        gamma[cols..(m + 1) * cols].copy_from_slice(&gam);
        let df = n as f64 - alpha * ldl.trace_inverse_times(&r.m0, &r.m1, &r.m2);
        Some(SmoothingSpline {
            t: t.to_vec(),
            cols,
            g,
            gamma,
            degrees_of_freedom: df,
        })
    }

    /// The GCV score `N · RSS / (N − tr A)²` pooled over the coordinates.
    fn gcv(&self, y: &[f64]) -> f64 {
        let n = self.t.len() as f64;
        let rss: f64 = y.iter().zip(&self.g).map(|(a, b)| (a - b) * (a - b)).sum();
        let free = n - self.degrees_of_freedom;
        if free <= 0.0 {
            return f64::INFINITY;
        }
        n * rss / (free * free)
    }

    /// The fitted value at abscissa `i`.
    pub(crate) fn value(&self, i: usize) -> &[f64] {
        &self.g[i * self.cols..(i + 1) * self.cols]
    }

    /// The spline at `x` (clamped to the abscissae's range), into `out`.
    pub(crate) fn evaluate(&self, x: f64, out: &mut [f64]) {
        let t = &self.t;
        let n = t.len();
        let x = x.clamp(t[0], t[n - 1]);
        let i = t.partition_point(|&u| u <= x).clamp(1, n - 1) - 1;
        let h = t[i + 1] - t[i];
        let (a, b) = (x - t[i], t[i + 1] - x);
        let c = self.cols;
        for k in 0..c {
            let (g0, g1) = (self.g[i * c + k], self.g[(i + 1) * c + k]);
            let (c0, c1) = (self.gamma[i * c + k], self.gamma[(i + 1) * c + k]);
            out[k] =
                (a * g1 + b * g0) / h - a * b / 6.0 * ((1.0 + a / h) * c1 + (1.0 + b / h) * c0);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_smoothing_spline_reproduces_a_straight_line_and_interpolates_as_alpha_vanishes() {
        let t: Vec<f64> = (0..20).map(|i| (i as f64 / 19.0).powf(1.5)).collect();
        let line: Vec<f64> = t.iter().map(|x| 2.0 * x - 1.0).collect();
        let s = SmoothingSpline::fit(&t, &line, 1, Smoothing::Lambda(10.0)).unwrap();
        for (i, y) in line.iter().enumerate() {
            assert!((s.value(i)[0] - y).abs() < 1e-12);
        }
        let mut out = [0.0];
        s.evaluate(0.3, &mut out);
        assert!((out[0] - (-0.4)).abs() < 1e-12);
        let wave: Vec<f64> = t.iter().map(|x| (6.0 * x).sin()).collect();
        let s = SmoothingSpline::fit(&t, &wave, 1, Smoothing::Lambda(1e-14)).unwrap();
        for (i, y) in wave.iter().enumerate() {
            assert!((s.value(i)[0] - y).abs() < 1e-8);
        }
        assert!((s.degrees_of_freedom - 20.0).abs() < 1e-3);
        let stiff = SmoothingSpline::fit(&t, &wave, 1, Smoothing::Lambda(1e6)).unwrap();
        assert!((stiff.degrees_of_freedom - 2.0).abs() < 1e-3);
    }

    #[test]
    fn the_trace_from_the_inverse_band_matches_a_dense_inverse() {
        let t: Vec<f64> = (0..9)
            .map(|i| (i as f64 * 0.7).sin() * 0.1 + i as f64)
            .collect();
        let r = Reinsch::new(&t);
        let alpha = 0.3;
        let m = t.len() - 2;
        let b0: Vec<f64> = (0..m).map(|j| r.r0[j] + alpha * r.m0[j]).collect();
        let b1: Vec<f64> = (0..m).map(|j| r.r1[j] + alpha * r.m1[j]).collect();
        let b2: Vec<f64> = (0..m).map(|j| alpha * r.m2[j]).collect();
        let ldl = PentaLdl::new(&b0, &b1, &b2).unwrap();
        // Dense: solve B x = M e_k column by column, sum the diagonal.
        let mm = |i: usize, j: usize| -> f64 {
            let (i, j) = (i.min(j), i.max(j));
            match j - i {
                0 => r.m0[i],
                1 => r.m1[i],
                2 => r.m2[i],
                _ => 0.0,
            }
        };
        let mut trace = 0.0;
        for k in 0..m {
            let mut col: Vec<f64> = (0..m).map(|i| mm(i, k)).collect();
            ldl.solve(&mut col, 1);
            trace += col[k];
        }
        let fast = ldl.trace_inverse_times(&r.m0, &r.m1, &r.m2);
        assert!(
            (fast - trace).abs() < 1e-10 * trace.abs(),
            "{fast} vs {trace}"
        );
    }

    #[test]
    fn gcv_smooths_noise_but_keeps_the_signal() {
        // A smooth signal plus centred uniform noise of half-width 0.05 (SplitMix64).
        let n = 200;
        let t: Vec<f64> = (0..n).map(|i| i as f64 / (n - 1) as f64).collect();
        let mut state: u64 = 59;
        let mut noise = || {
            state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = state;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^= z >> 31;
            0.1 * ((z >> 11) as f64 / (1u64 << 53) as f64 - 0.5)
        };
        let y: Vec<f64> = (0..n).map(|i| (3.0 * t[i]).sin() + noise()).collect();
        let s = SmoothingSpline::fit(&t, &y, 1, Smoothing::Gcv).unwrap();
        let err: f64 = (0..n)
            .map(|i| (s.value(i)[0] - (3.0 * t[i]).sin()).abs())
            .fold(0.0, f64::max);
        // Interpolating the noise would leave errors up to 0.05; a straight line, up to 0.6.
        assert!(err < 0.02, "{err}");
        let df = s.degrees_of_freedom;
        assert!((3.0..20.0).contains(&df), "{df}");
    }
}
