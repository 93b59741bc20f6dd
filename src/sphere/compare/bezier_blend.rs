//! Gousenbourger et al.'s composite Bézier-like curves (CBC) and blended cubic splines (BCC)
//! (P.-Y. Gousenbourger, E. Massart & P.-A. Absil, "Data fitting on manifolds with composite
//! Bézier-like curves and blended cubic splines", Journal of Mathematical Imaging and Vision
//! 61, 2019, pp. 645–671; the GLS-PIA paper's \[GMA18\]).
//!
//! Both solve, in a tangent space, the Euclidean problem
//! `min ½ Σ_i ‖B(t_i) − x_i‖² + (λ/2) ∫₀¹ ‖B''‖²` over **C¹ composite cubic Bézier curves**
//! with `K` segments joined at `t = k / K`, `x_i = log(p_i)` the data mapped to that tangent
//! space. The C¹ curves are parameterised by their free points — the first joint, the first
//! inner control point, then per segment its second inner control point and its end joint
//! (the next segment's first inner point is the reflection `2 J − b`), `2K + 2` points — so
//! the problem is one banded linear system (half-bandwidth 3), solved by band Cholesky in
//! O(points + K).
//!
//! * **CBC** (`cbc`): one tangent space, at the base point `m / |m|` (`m` the mean of the
//!   data vectors). The control points are mapped back by `exp`, then each segment's first
//!   inner point is replaced by the reflection of the previous segment's second inner point
//!   through their joint, `exp_J(−log_J b)`, which makes the curve C¹ on the sphere
//!   (Gousenbourger et al.'s construction); each segment is a spherical Bézier curve evaluated
//!   by the Riemannian de Casteljau algorithm (SLERP, [`crate::sphere::SphericalBezier`]).
//! * **BCC** (`bcc`): local fits instead of one global one. At each joint `j` (the data
//!   polyline at `t = j / K`, the anchor `a_j`) the same Euclidean problem is solved in
//!   `T_{a_j}` over the [`WINDOW`] segments on either side of it, and its curve `A_j(t) =
//!   exp_{a_j}(B_j(t))`; on segment `k` the curve is the geodesic blend
//!   `slerp(A_k(t), A_{k+1}(t), w(s))`, `w(s) = 3s² − 2s³`, which is C¹ because `w` has zero
//!   slope at both ends.
//!
//! Choices the paper leaves open, made here:
//! * The number of segments: the largest `K` with `2K + 2` free points within the budget
//!   ([`super::MethodOptions::control_points`]), so CBC has at most GLS-PIA's degrees of
//!   freedom. Joints are evenly spaced in parameter (chord length by default).
//! * The base point of CBC: the normalised extrinsic mean of the data (the Karcher mean is
//!   within O(spread³) of it and needs an iteration of its own). Data spread so evenly that
//!   the mean vanishes, or a point (nearly) antipodal to the base, are refused
//!   ([`CompareError::NoTangentBase`]).
//! * λ: [`super::DEFAULT_LAMBDA`] unless given: a fit driven by the data (Gousenbourger et
//!   al. study the whole range from λ → ∞, interpolation, to small values).
//! * BCC's window: [`WINDOW`] segments on each side of the anchor, widened one at a time when
//!   a window holds too few points for its system.

use crate::sphere::compare::{CompareError, Fitted, MethodOptions};
use crate::sphere::curve::bezier::SphericalBezier;
use crate::sphere::geometry::point::{
    exp_in_place, log_into, normalize, slerp, Arc, Dynamic, PointSet,
};
use crate::sphere::linalg::banded::SymmetricBand;

/// Segments on each side of a BCC anchor that its local fit covers.
pub const WINDOW: usize = 2;

/// The number of Bézier segments whose `2K + 2` free points fit in `budget` (at least 1).
pub fn segments_for(budget: usize) -> usize {
    (budget.saturating_sub(2) / 2).max(1)
}

/// The segment holding parameter `t` of `k` segments on [0, 1], and the fraction along it.
fn locate(t: f64, k: usize) -> (usize, f64) {
    let x = t.clamp(0.0, 1.0) * k as f64;
    let j = (x.floor() as usize).min(k - 1);
    (j, (x - j as f64).clamp(0.0, 1.0))
}

/// The cubic Bernstein weights at `s`.
fn bernstein(s: f64) -> [f64; 4] {
    let r = 1.0 - s;
    [r * r * r, 3.0 * r * r * s, 3.0 * r * s * s, s * s * s]
}

/// The four Bézier points of local segment `j` as combinations of the free points: for each
/// Bézier point, pairs (free index, coefficient).
fn bezier_of_free(j: usize) -> [[(usize, f64); 2]; 4] {
    if j == 0 {
        [
            [(0, 1.0), (0, 0.0)],
            [(1, 1.0), (1, 0.0)],
            [(2, 1.0), (2, 0.0)],
            [(3, 1.0), (3, 0.0)],
        ]
    } else {
        let b = 2 * j;
        [
            [(b + 1, 1.0), (b + 1, 0.0)],
            [(b + 1, 2.0), (b, -1.0)],
            [(b + 2, 1.0), (b + 2, 0.0)],
            [(b + 3, 1.0), (b + 3, 0.0)],
        ]
    }
}

/// The weights of `B(t)` on the free points `2j .. 2j + 4` for local segment `j` at `s`.
fn free_weights(j: usize, s: f64) -> (usize, [f64; 4]) {
    let beta = bernstein(s);
    let first = if j == 0 { 0 } else { 2 * j };
    let mut w = [0.0; 4];
    for (bp, pairs) in bezier_of_free(j).iter().enumerate() {
        for &(idx, c) in pairs {
            w[idx - first] += c * beta[bp];
        }
    }
    (first, w)
}

/// `∫‖B''‖²` over local segment `j` (one of `k` on [0, 1]) as a quadratic form in its four
/// free points `2j .. 2j + 4`: with `B'' = 6k² (A (1 − s) + C s)`, `A = b₀ − 2b₁ + b₂`,
/// `C = b₁ − 2b₂ + b₃`, the integral is `12k³ (|A|² + A·C + |C|²)`.
fn penalty_block(j: usize, k: usize) -> [[f64; 4]; 4] {
    let kk = k as f64;
    let (k3_12, k3_6) = (12.0 * kk * kk * kk, 6.0 * kk * kk * kk);
    let av = [1.0, -2.0, 1.0, 0.0];
    let cv = [0.0, 1.0, -2.0, 1.0];
    let mut gb = [[0.0; 4]; 4];
    for p in 0..4 {
        for q in 0..4 {
            gb[p][q] =
                k3_12 * (av[p] * av[q] + cv[p] * cv[q]) + k3_6 * (av[p] * cv[q] + cv[p] * av[q]);
        }
    }
    let first = if j == 0 { 0 } else { 2 * j };
    let mut t_map = [[0.0; 4]; 4];
    for (bp, pairs) in bezier_of_free(j).iter().enumerate() {
        for &(idx, c) in pairs {
            t_map[bp][idx - first] += c;
        }
    }
    let mut out = [[0.0; 4]; 4];
    for p in 0..4 {
        for q in 0..4 {
            for r in 0..4 {
                for s in 0..4 {
                    out[p][q] += t_map[r][p] * gb[r][s] * t_map[s][q];
                }
            }
        }
    }
    out
}

/// The Euclidean C¹ composite cubic Bézier fit over segments `lo..hi` of `k` on [0, 1]: the
/// data `x` (`cols` values per point) at parameters `t`, smoothing weight `lambda`. Returns
/// the Bézier points, 4 per segment (`cols` values each), or `None` when the system is
/// singular.
fn euclidean_fit(
    t: &[f64],
    x: &[f64],
    cols: usize,
    (lo, hi, k): (usize, usize, usize),
    lambda: f64,
) -> Option<Vec<f64>> {
    let l = hi - lo;
    let unknowns = 2 * l + 2;
    let mut a = SymmetricBand::zeros(unknowns, 3);
    let mut rhs = vec![0.0; unknowns * cols];
    for (i, &ti) in t.iter().enumerate() {
        let (seg, s) = locate(ti, k);
        if seg < lo || seg >= hi {
            continue;
        }
        let (first, w) = free_weights(seg - lo, s);
        for p in 0..4 {
            for q in p..4 {
                a.add_upper(first + p, first + q, w[p] * w[q]);
            }
            for c in 0..cols {
                rhs[(first + p) * cols + c] += w[p] * x[i * cols + c];
            }
        }
    }
    if lambda > 0.0 {
        for j in 0..l {
            let first = if j == 0 { 0 } else { 2 * j };
            let p = penalty_block(j, k);
            for r in 0..4 {
                for c in r..4 {
                    a.add_upper(first + r, first + c, lambda * p[r][c]);
                }
            }
        }
    }
    let chol = a.cholesky(0.0, 0.0)?;
    chol.solve_in_place(&mut rhs, cols);
    if rhs.iter().any(|v| !v.is_finite()) {
        return None;
    }
    let mut out = vec![0.0; l * 4 * cols];
    for j in 0..l {
        for (bp, pairs) in bezier_of_free(j).iter().enumerate() {
            for &(idx, c) in pairs {
                for col in 0..cols {
                    out[(j * 4 + bp) * cols + col] += c * rhs[idx * cols + col];
                }
            }
        }
    }
    Some(out)
}

/// Fits a CBC curve with the largest number of segments within `budget` free points.
pub(crate) fn cbc(
    points: &PointSet,
    params: &[f64],
    budget: usize,
    options: &MethodOptions,
    ts: &[f64],
) -> Result<Fitted, CompareError> {
    let dim = points.dim();
    let d = Dynamic(dim);
    let k = segments_for(budget);
    let mut base = vec![0.0; dim];
    for p in points.iter() {
        for (b, x) in base.iter_mut().zip(p) {
            *b += x;
        }
    }
    let norm = normalize(d, &mut base);
    if norm < 1e-9 * points.len() as f64 {
        return Err(CompareError::NoTangentBase {
            reason: format!(
                "the mean of the {} points has length {norm:e}: they surround the sphere",
                points.len()
            ),
        });
    }
    let mut x = vec![0.0; points.len() * dim];
    for (i, p) in points.iter().enumerate() {
        let arc = Arc::between(d, &base, p);
        if arc.is_near_antipodal() {
            return Err(CompareError::NoTangentBase {
                reason: format!(
                    "point {i} is (nearly) antipodal to the mean direction ({} rad)",
                    arc.theta
                ),
            });
        }
        log_into(d, &base, p, &mut x[i * dim..(i + 1) * dim]);
    }
    let tangent = euclidean_fit(params, &x, dim, (0, k, k), options.lambda).ok_or_else(|| {
        CompareError::Singular {
            method: "cbc",
            reason: format!(
                "the fit of {k} segments has no unique solution: give lambda > 0 or fewer control points"
            ),
        }
    })?;
    // Map back by exp at the base.
    let mut ctrl = vec![0.0; k * 4 * dim];
    for (q, v) in ctrl.chunks_exact_mut(dim).zip(tangent.chunks_exact(dim)) {
        q.copy_from_slice(&base);
        exp_in_place(d, q, v);
    }
    // C¹ on the sphere: b_{j,1} = exp_J(−log_J b_{j−1,2}).
    let mut v = vec![0.0; dim];
    for j in 1..k {
        let joint = ctrl[(j * 4) * dim..(j * 4 + 1) * dim].to_vec();
        let prev = ctrl[((j - 1) * 4 + 2) * dim..((j - 1) * 4 + 3) * dim].to_vec();
        log_into(d, &joint, &prev, &mut v);
        v.iter_mut().for_each(|c| *c = -*c);
        let mut q = joint.clone();
        exp_in_place(d, &mut q, &v);
        ctrl[(j * 4 + 1) * dim..(j * 4 + 2) * dim].copy_from_slice(&q);
    }
    let segments: Vec<SphericalBezier> = ctrl
        .chunks_exact(4 * dim)
        .map(|c| SphericalBezier::try_new(PointSet::from_flat_unchecked(dim, c.to_vec())))
        .collect::<Result<_, _>>()?;
    let eval = |t: f64| {
        let (j, s) = locate(t, k);
        segments[j].evaluate(s)
    };
    let fitted: Vec<f64> = params.iter().flat_map(|&t| eval(t)).collect();
    let samples: Vec<f64> = ts.iter().flat_map(|&t| eval(t)).collect();
    Ok(Fitted {
        fitted: PointSet::from_flat_unchecked(dim, fitted),
        samples: PointSet::from_flat_unchecked(dim, samples),
        iterations: 0,
        converged: true,
        free_points: 2 * k + 2,
    })
}

/// One BCC anchor: its point, the first segment of its window, and its Euclidean Bézier
/// points in its tangent space (4 per segment of the window).
struct Anchor {
    point: Vec<f64>,
    lo: usize,
    bezier: Vec<f64>,
}

impl Anchor {
    /// `A_j(t) = exp_{a_j}(B_j(t))` for `t` in segment `seg` (inside the window) at `s`.
    fn at(&self, seg: usize, s: f64) -> Vec<f64> {
        let dim = self.point.len();
        let beta = bernstein(s);
        let j = seg - self.lo;
        let mut v = vec![0.0; dim];
        for (bp, w) in beta.iter().enumerate() {
            let q = &self.bezier[(j * 4 + bp) * dim..(j * 4 + bp + 1) * dim];
            for c in 0..dim {
                v[c] += w * q[c];
            }
        }
        let mut p = self.point.clone();
        exp_in_place(Dynamic(dim), &mut p, &v);
        p
    }
}

/// Fits a BCC curve with the largest number of segments within `budget` free points.
pub(crate) fn bcc(
    points: &PointSet,
    params: &[f64],
    budget: usize,
    options: &MethodOptions,
    ts: &[f64],
) -> Result<Fitted, CompareError> {
    let dim = points.dim();
    let d = Dynamic(dim);
    let k = segments_for(budget);
    let taus: Vec<f64> = (0..=k).map(|j| j as f64 / k as f64).collect();
    let anchors_at = super::polyline_at(points, params, &taus);
    let mut anchors = Vec::with_capacity(k + 1);
    for j in 0..=k {
        let a = anchors_at.get(j).to_vec();
        let mut window = WINDOW;
        let anchor = loop {
            let lo = j.saturating_sub(window);
            let hi = (j + window).min(k);
            let t_lo = lo as f64 / k as f64;
            let t_hi = hi as f64 / k as f64;
            let first = params.partition_point(|&t| t < t_lo);
            let last = params.partition_point(|&t| t <= t_hi);
            let mut x = vec![0.0; (last - first) * dim];
            for (r, i) in (first..last).enumerate() {
                let p = points.get(i);
                if Arc::between(d, &a, p).is_near_antipodal() {
                    return Err(CompareError::Singular {
                        method: "bcc",
                        reason: format!(
                            "point {i} is (nearly) antipodal to the anchor at joint {j}"
                        ),
                    });
                }
                log_into(d, &a, p, &mut x[r * dim..(r + 1) * dim]);
            }
            let fit = euclidean_fit(
                &params[first..last],
                &x,
                dim,
                (lo, hi.max(lo + 1), k),
                options.lambda,
            );
            match fit {
                Some(bezier) => break Anchor { point: a.clone(), lo, bezier },
                None if lo == 0 && hi == k => {
                    return Err(CompareError::Singular {
                        method: "bcc",
                        reason: format!(
                            "the local fit at joint {j} has no unique solution even over all {k} segments: give lambda > 0 or fewer control points"
                        ),
                    })
                }
                None => window += 1,
            }
        };
        anchors.push(anchor);
    }
    let eval = |t: f64| -> Result<Vec<f64>, CompareError> {
        let (j, s) = locate(t, k);
        let a = anchors[j].at(j, s);
        let b = anchors[j + 1].at(j, s);
        let w = s * s * (3.0 - 2.0 * s);
        Ok(slerp(&a, &b, w)?)
    };
    let mut fitted = Vec::with_capacity(params.len() * dim);
    for &t in params {
        fitted.extend(eval(t)?);
    }
    let mut samples = Vec::with_capacity(ts.len() * dim);
    for &t in ts {
        samples.extend(eval(t)?);
    }
    Ok(Fitted {
        fitted: PointSet::from_flat_unchecked(dim, fitted),
        samples: PointSet::from_flat_unchecked(dim, samples),
        iterations: 0,
        converged: true,
        free_points: 2 * k + 2,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_euclidean_fit_reproduces_a_cubic_exactly() {
        // A cubic is one Bézier piece, hence a C¹ composite of any number of pieces.
        let t: Vec<f64> = (0..50).map(|i| i as f64 / 49.0).collect();
        let f = |u: f64| [u * u * u - u, 0.5 * u * u + 0.2];
        let x: Vec<f64> = t.iter().flat_map(|&u| f(u)).collect();
        let b = euclidean_fit(&t, &x, 2, (0, 5, 5), 0.0).unwrap();
        for &u in &t {
            let (j, s) = locate(u, 5);
            let beta = bernstein(s);
            for c in 0..2 {
                let v: f64 = (0..4).map(|p| beta[p] * b[(j * 4 + p) * 2 + c]).sum();
                assert!((v - f(u)[c]).abs() < 1e-12, "{u} {c}: {v}");
            }
        }
        // A straight line has no second derivative: any λ leaves it as it is.
        let line: Vec<f64> = t.iter().flat_map(|&u| [2.0 * u - 1.0, 0.3]).collect();
        let b = euclidean_fit(&t, &line, 2, (0, 5, 5), 10.0).unwrap();
        let (j, s) = locate(0.3, 5);
        let beta = bernstein(s);
        let v: f64 = (0..4).map(|p| beta[p] * b[(j * 4 + p) * 2]).sum();
        assert!((v - (-0.4)).abs() < 1e-12, "{v}");
    }

    #[test]
    fn the_penalty_block_is_the_integral_of_the_squared_second_derivative() {
        let k = 4;
        for j in [0, 2] {
            let z = [0.3, -1.1, 0.7, 2.0];
            let p = penalty_block(j, k);
            let form: f64 = (0..4)
                .flat_map(|r| (0..4).map(move |c| (r, c)))
                .map(|(r, c)| z[r] * p[r][c] * z[c])
                .sum();
            // The Bézier points from the free ones, then ∫ B''² dt by the midpoint rule.
            let first = if j == 0 { 0 } else { 2 * j };
            let b: Vec<f64> = bezier_of_free(j)
                .iter()
                .map(|pairs| pairs.iter().map(|&(i, c)| c * z[i - first]).sum())
                .collect();
            let steps = 20_000;
            let kk = k as f64;
            let integral: f64 = (0..steps)
                .map(|i| {
                    let s = (i as f64 + 0.5) / steps as f64;
                    let a = b[0] - 2.0 * b[1] + b[2];
                    let c = b[1] - 2.0 * b[2] + b[3];
                    let d2 = 6.0 * kk * kk * (a * (1.0 - s) + c * s);
                    d2 * d2 / (kk * steps as f64)
                })
                .sum();
            assert!(
                (form - integral).abs() < 1e-6 * integral,
                "{form} vs {integral}"
            );
        }
    }

    #[test]
    fn free_points_make_the_joints_c1() {
        // Segment j ≥ 1 starts at its joint with the reflected inner point.
        let m = bezier_of_free(2);
        assert_eq!(m[0][0], (5, 1.0));
        assert_eq!(m[1], [(5, 2.0), (4, -1.0)]);
        assert_eq!(segments_for(4), 1);
        assert_eq!(segments_for(30), 14);
    }
}
