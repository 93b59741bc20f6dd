//! Exact derivatives of a spherical B-spline point C(t) with respect to its control points, for
//! the Gauss–Newton solver.
//!
//! Each control point P_i moves in its tangent plane, with coordinates in an orthonormal basis
//! of P_i^⊥ (`dim − 1` of them). The derivative is pushed forward through the same de Boor
//! triangle that evaluates C(t): a SLERP node `o = w0(θ, α) a + w1(θ, α) b` with
//! `θ = angle(a, b)` has
//!
//! `do = w0 da + w1 db − (g0 a + g1 b) (b·da + a·db)`, with `g = (∂w/∂θ) / sin θ`,
//!
//! (for unit a, b and tangent da, db, `dθ = −(b·da + a·db) / sin θ`). Unlike the contribution
//! coefficients D_i alone, this includes how the SLERP weights change with the control points,
//! so Gauss–Newton converges quadratically to the geodesic least-squares optimum.

use crate::sphere::curve::bspline::SphericalBSpline;
use crate::sphere::geometry::point::{sinc_series, Arc, PointSet, SERIES_ANGLE_MAX_RAD};

/// Orthonormal bases of the tangent planes of every control point: `dim − 1` vectors of `dim`
/// coordinates per point, from the Householder reflection that maps P to ±e_0.
pub(crate) fn tangent_bases(control: &PointSet) -> Vec<f64> {
    let dim = control.dim();
    let mut out = Vec::with_capacity(control.len() * (dim - 1) * dim);
    let mut u = vec![0.0; dim];
    for p in control.iter() {
        // H = I − 2 u uᵀ / |u|², u = P + sign(P_0) e_0, maps P to −sign(P_0) e_0; its columns
        // 1..dim are an orthonormal basis of P^⊥.
        u.copy_from_slice(p);
        let s = if p[0] >= 0.0 { 1.0 } else { -1.0 };
        u[0] += s;
        let uu: f64 = u.iter().map(|x| x * x).sum();
        for c in 1..dim {
            let f = 2.0 * u[c] / uu;
            for (x, ux) in u.iter().enumerate() {
                out.push(if x == c { 1.0 } else { 0.0 } - f * ux);
            }
        }
    }
    out
}

/// T(y) with sinc'(x) = x T(x²), for x² = y <= SERIES_ANGLE_MAX_RAD²: the Taylor series
/// Σ_{n>=1} (−1)^n 2n y^(n−1) / (2n+1)! through n = 6 (the omitted term is < 1e-18 relative).
#[inline]
fn sinc_deriv_series(y: f64) -> f64 {
    -1.0 / 3.0
        + y * (1.0 / 30.0
            + y * (-1.0 / 840.0
                + y * (1.0 / 45_360.0 + y * (-1.0 / 3_991_680.0 + y * (1.0 / 518_918_400.0)))))
}

/// SLERP weights `(w0, w1)` at `alpha` on an arc of angle `theta`, and `(g0, g1)`, their
/// derivatives with respect to theta divided by sin theta (finite as theta → 0).
pub(crate) fn weights_and_slopes(arc: &Arc, alpha: f64) -> (f64, f64, f64, f64) {
    let theta = arc.theta;
    if theta <= SERIES_ANGLE_MAX_RAD {
        let s_t = sinc_series(theta);
        let t_t = sinc_deriv_series(theta * theta);
        let one = |a: f64| {
            let x = a * theta;
            let s_x = sinc_series(x);
            let w = a * s_x / s_t;
            // g = a (a² T(a²θ²) S(θ) − S(aθ) T(θ²)) / S(θ)³
            let g = a * (a * a * sinc_deriv_series(x * x) * s_t - s_x * t_t) / (s_t * s_t * s_t);
            (w, g)
        };
        let (w0, g0) = one(1.0 - alpha);
        let (w1, g1) = one(alpha);
        (w0, w1, g0, g1)
    } else {
        let (sin, cos) = (arc.sin_theta.max(1e-300), arc.cos_theta);
        let one = |a: f64| {
            let (s, c) = (a * theta).sin_cos();
            let w = s / sin;
            let dw = (a * c * sin - s * cos) / (sin * sin);
            (w, dw / sin)
        };
        let (w0, g0) = one(1.0 - alpha);
        let (w1, g1) = one(alpha);
        (w0, w1, g0, g1)
    }
}

/// Working memory for [`eval_with_jacobian`].
pub(crate) struct JacobianScratch {
    tri: Vec<f64>,
    dtri: Vec<f64>,
    /// After an evaluation: `jac[dir * dim + x]`, the derivative of C(t) along tangent direction
    /// `dir = m (dim − 1) + a` (basis vector a of control k − p + m).
    pub jac: Vec<f64>,
}

impl JacobianScratch {
    pub(crate) fn new(p: usize, dim: usize) -> JacobianScratch {
        let ndir = (p + 1) * (dim - 1);
        JacobianScratch {
            tri: vec![0.0; (p + 1) * dim],
            dtri: vec![0.0; (p + 1) * ndir * dim],
            jac: vec![0.0; ndir * dim],
        }
    }
}

/// Evaluates C(t) in span k of `spline` into `out` and its derivatives into `s.jac`, along the
/// tangent `bases` of its control points ([`tangent_bases`]).
pub(crate) fn eval_with_jacobian(
    spline: &SphericalBSpline,
    bases: &[f64],
    k: usize,
    t: f64,
    s: &mut JacobianScratch,
    out: &mut [f64],
) {
    let (p, knots, control) = (spline.degree(), spline.knots(), spline.control_points());
    let dim = control.dim();
    let nb = dim - 1;
    let ndir = (p + 1) * nb;
    let n_ctrl = control.len();
    let t = t.clamp(knots[p], knots[n_ctrl]);
    let first = k - p;
    s.tri
        .copy_from_slice(&control.as_flat()[first * dim..(k + 1) * dim]);
    // Node j's derivative along direction dir: dtri[(j * ndir + dir) * dim ..].
    s.dtri.iter_mut().for_each(|x| *x = 0.0);
    for j in 0..=p {
        let basis = &bases[(first + j) * nb * dim..(first + j + 1) * nb * dim];
        for a in 0..nb {
            let dir = j * nb + a;
            s.dtri[(j * ndir + dir) * dim..(j * ndir + dir + 1) * dim]
                .copy_from_slice(&basis[a * dim..(a + 1) * dim]);
        }
    }
    let d = crate::sphere::geometry::point::Dynamic(dim);
    for r in 1..=p {
        for j in (r..=p).rev() {
            let i = first + j;
            let alpha = (t - knots[i]) / (knots[i + p - r + 1] - knots[i]);
            let (left, right) = s.tri.split_at_mut(j * dim);
            let a = &left[(j - 1) * dim..j * dim];
            let b = &mut right[..dim];
            let arc = Arc::between(d, a, b);
            let (w0, w1, g0, g1) = weights_and_slopes(&arc, alpha);
            // Directions that reach this node: those of controls j − r ..= j.
            let (dl, dr) = s.dtri.split_at_mut(j * ndir * dim);
            let da_all = &dl[(j - 1) * ndir * dim..];
            let db_all = &mut dr[..ndir * dim];
            for dir in (j - r) * nb..(j + 1) * nb {
                let da = &da_all[dir * dim..(dir + 1) * dim];
                let db = &mut db_all[dir * dim..(dir + 1) * dim];
                let mut c = 0.0;
                for x in 0..dim {
                    c += b[x] * da[x] + a[x] * db[x];
                }
                for x in 0..dim {
                    db[x] = w0 * da[x] + w1 * db[x] - c * (g0 * a[x] + g1 * b[x]);
                }
            }
            for x in 0..dim {
                b[x] = w0 * a[x] + w1 * b[x];
            }
        }
    }
    let apex = &s.tri[p * dim..(p + 1) * dim];
    let norm = apex.iter().map(|x| x * x).sum::<f64>().sqrt();
    for x in 0..dim {
        out[x] = apex[x] / norm;
    }
    let dapex = &s.dtri[p * ndir * dim..(p + 1) * ndir * dim];
    for dir in 0..ndir {
        let dv = &dapex[dir * dim..(dir + 1) * dim];
        let along: f64 = (0..dim).map(|x| out[x] * dv[x]).sum();
        for x in 0..dim {
            s.jac[dir * dim + x] = (dv[x] - along * out[x]) / norm;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sphere::geometry::point::{exp_map, Dynamic};
    use crate::sphere::SphericalBSpline;

    fn spline(spread: f64) -> SphericalBSpline {
        let rows: Vec<Vec<f64>> = (0..7)
            .map(|i| {
                let a = spread * i as f64;
                let lat = spread * (1.7 * i as f64).sin();
                vec![lat.cos() * a.cos(), lat.cos() * a.sin(), lat.sin()]
            })
            .collect();
        let knots = vec![0., 0., 0., 0., 0.2, 0.5, 0.7, 1., 1., 1., 1.];
        SphericalBSpline::try_new(3, knots, PointSet::try_from_rows(&rows).unwrap()).unwrap()
    }

    #[test]
    fn jacobian_matches_finite_differences() {
        for spread in [1e-3, 0.1, 0.6] {
            let s = spline(spread);
            let bases = tangent_bases(s.control_points());
            for t in [0.05, 0.33, 0.6, 0.95] {
                let mut scratch = JacobianScratch::new(3, 3);
                let mut c = [0.0; 3];
                let k = s.knots().partition_point(|&u| u <= t) - 1;
                eval_with_jacobian(&s, &bases, k, t, &mut scratch, &mut c);
                let direct = s.evaluate(t);
                assert!((0..3).all(|x| (c[x] - direct[x]).abs() < 1e-15));
                let h = 1e-6;
                for m in 0..4 {
                    for a in 0..2 {
                        let i = k - 3 + m;
                        let basis = &bases[(i * 2 + a) * 3..(i * 2 + a + 1) * 3];
                        let moved = |sign: f64| {
                            let mut rows = s.control_points().to_rows();
                            let v: Vec<f64> = basis.iter().map(|x| sign * h * x).collect();
                            rows[i] = exp_map(&rows[i], &v).unwrap();
                            let cp = PointSet::try_from_rows(&rows).unwrap();
                            SphericalBSpline::try_new(3, s.knots().to_vec(), cp)
                                .unwrap()
                                .evaluate(t)
                        };
                        let (plus, minus) = (moved(1.0), moved(-1.0));
                        let dir = m * 2 + a;
                        for x in 0..3 {
                            let fd = (plus[x] - minus[x]) / (2.0 * h);
                            let an = scratch.jac[dir * 3 + x];
                            assert!(
                                (fd - an).abs() < 1e-7,
                                "spread {spread} t {t} dir {dir}: fd {fd} vs {an}"
                            );
                        }
                    }
                }
            }
        }
        let _ = Dynamic(3);
    }

    #[test]
    fn tangent_bases_are_orthonormal_and_tangent() {
        let s = spline(0.4);
        let b = tangent_bases(s.control_points());
        for (i, p) in s.control_points().iter().enumerate() {
            let e = |a: usize| &b[(i * 2 + a) * 3..(i * 2 + a + 1) * 3];
            let dot = |u: &[f64], v: &[f64]| u.iter().zip(v).map(|(x, y)| x * y).sum::<f64>();
            assert!(dot(e(0), p).abs() < 1e-15 && dot(e(1), p).abs() < 1e-15);
            assert!((dot(e(0), e(0)) - 1.0).abs() < 1e-15 && dot(e(0), e(1)).abs() < 1e-15);
        }
    }
}
