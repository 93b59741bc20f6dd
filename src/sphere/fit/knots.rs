//! Data parameters and knot placement (GLS-PIA paper §4), and the initial control points.
//!
//! * Parameters: chord length by geodesic distance (default), centripetal (square roots of the
//!   geodesic distances), uniform, or given by the caller (timestamps), normalised to [0, 1].
//! * Knots: uniform, or adaptive from k-th differences of the data (eqs. 6–17): the feature
//!   function `|q^(p)|^(1/p)` is integrated to a CDF and knots are placed at equal CDF levels.
//!   Geodesic differences project onto the tangent plane at the (normalised) midpoint of the
//!   two bases (eq. 8); Euclidean differences do not. See `../shared/METHOD.md` for the reading
//!   of the garbled formulas.
//! * Initial control points: the data polyline (SLERP between neighbours) at the Greville
//!   abscissae of the knots (§4.3).

use crate::sphere::curve::bspline::clamped_uniform_knots;
use crate::sphere::geometry::point::{dot, normalize, slerp, Arc, Dim, Dynamic, PointSet};
use crate::sphere::SphereError;
use serde::{Deserialize, Serialize};

/// How data points get their curve parameters.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Parameterization {
    /// Cumulative geodesic distance (the paper's chord length on the sphere).
    #[default]
    Chord,
    /// Cumulative square root of the geodesic distance (less overshoot at sharp turns).
    Centripetal,
    /// Equally spaced, ignoring geometry.
    Uniform,
}

/// Where the interior knots go.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum KnotPlacement {
    /// Feature function from geodesic (tangent-plane) differences: the paper's method.
    #[default]
    Geodesic,
    /// Feature function from Euclidean differences of the unit vectors.
    Euclidean,
    /// Equally spaced in parameter.
    Uniform,
    /// The geodesic feature function made fit for real lines: sharp corners become C0 joints
    /// (knots of multiplicity p), differences stop at corners, and the CDF is mixed with arc
    /// length so sparse straight stretches keep knots ([`super::adaptive_knots`]).
    Adaptive,
}

from_names!(Parameterization, "parameterization", "chord, centripetal or uniform" {
    "chord" => Chord,
    "centripetal" => Centripetal,
    "uniform" => Uniform,
});

from_names!(KnotPlacement, "knot placement", "adaptive, geodesic, euclidean or uniform" {
    "geodesic" => Geodesic,
    "euclidean" => Euclidean,
    "uniform" => Uniform,
    "adaptive" => Adaptive,
});

/// Smallest gap between neighbouring interior knots, as a fraction of the uniform spacing
/// `1 / (N - p)`. Difference-based knots may pile up (on data made of great-circle arcs they
/// land exactly on the corners); keeping them a hair apart leaves no empty span while still
/// behaving like a multiple knot.
pub const MIN_KNOT_GAP_FRACTION: f64 = 1e-6;

/// Parameters for `points`, normalised to [0, 1]. Repeated consecutive points get equal
/// parameters.
///
/// # Errors
/// [`SphereError::AllPointsEqual`] when the points have no extent (chord, centripetal), or
/// fewer than 2 points.
pub fn parameters(points: &PointSet, method: Parameterization) -> Result<Vec<f64>, SphereError> {
    let n = points.len();
    if n < 2 {
        return Err(SphereError::TooFewPoints { got: n, need: 2 });
    }
    let d = Dynamic(points.dim());
    let mut t = Vec::with_capacity(n);
    t.push(0.0);
    let mut acc = 0.0;
    for i in 1..n {
        let step = match method {
            Parameterization::Uniform => 1.0,
            Parameterization::Chord => Arc::between(d, points.get(i - 1), points.get(i)).theta,
            Parameterization::Centripetal => Arc::between(d, points.get(i - 1), points.get(i))
                .theta
                .sqrt(),
        };
        acc += step;
        t.push(acc);
    }
    if acc <= 0.0 {
        return Err(SphereError::AllPointsEqual { count: n });
    }
    for x in t.iter_mut() {
        *x /= acc;
    }
    t[n - 1] = 1.0;
    Ok(t)
}

/// Normalises caller-given parameters (timestamps, distances) to [0, 1].
///
/// # Errors
/// A count different from the points, a non-finite value, a decrease (naming the index), or
/// all values equal.
pub fn normalize_parameters(given: &[f64], count: usize) -> Result<Vec<f64>, SphereError> {
    let bad = |reason: String| Err(SphereError::InvalidParameters { reason });
    if given.len() != count {
        return bad(format!(
            "got {} parameters for {count} points; give one per point",
            given.len()
        ));
    }
    if let Err(reason) = crate::sphere::finite_non_decreasing(given, "parameter") {
        return bad(reason);
    }
    let (a, b) = (given[0], given[given.len() - 1]);
    if b <= a {
        return bad("all parameters are equal: they span no interval".to_string());
    }
    if !(b - a).is_finite() {
        return bad("the parameters span more than the largest finite number: rescale them".into());
    }
    let mut t: Vec<f64> = given.iter().map(|x| (x - a) / (b - a)).collect();
    let last = t.len() - 1;
    t[last] = 1.0;
    Ok(t)
}

/// A clamped knot vector on [0, 1] for `n_ctrl` control points of degree `p`.
///
/// # Errors
/// When `n_ctrl < p + 1`.
pub fn place_knots(
    points: &PointSet,
    params: &[f64],
    n_ctrl: usize,
    p: usize,
    placement: KnotPlacement,
) -> Result<Vec<f64>, SphereError> {
    if n_ctrl < p + 1 {
        return Err(SphereError::InvalidControlPointCount {
            got: n_ctrl,
            degree: p,
            min: p + 1,
            max: points.len(),
        });
    }
    let interior = match placement {
        KnotPlacement::Adaptive => {
            let cfg = super::adaptive_knots::AdaptiveKnots::default();
            return Ok(super::adaptive_knots::place(
                points, params, n_ctrl, p, &cfg,
            ));
        }
        KnotPlacement::Uniform => uniform_interior(n_ctrl, p),
        KnotPlacement::Euclidean | KnotPlacement::Geodesic => {
            let geodesic = placement == KnotPlacement::Geodesic;
            let (nodes_u, nodes_f) = feature_function(points, params, p, geodesic);
            match invert_cdf(&nodes_u, &nodes_f, n_ctrl - p) {
                Some(levels) => levels,
                None => uniform_interior(n_ctrl, p),
            }
        }
    };
    Ok(clamp_knots(interior, n_ctrl, p))
}

fn uniform_interior(n_ctrl: usize, p: usize) -> Vec<f64> {
    clamped_uniform_knots(n_ctrl, p)[p + 1..n_ctrl].to_vec()
}

/// Clamped knots around `interior` (values in (0, 1)), spread so that no two are closer than
/// [`MIN_KNOT_GAP_FRACTION`] of the uniform spacing.
fn clamp_knots(mut interior: Vec<f64>, n_ctrl: usize, p: usize) -> Vec<f64> {
    let m = interior.len();
    let gap = MIN_KNOT_GAP_FRACTION / (n_ctrl - p) as f64;
    // Forward pass keeps each knot at least `gap` after its predecessor (and after 0) ...
    let mut prev = 0.0;
    for u in interior.iter_mut() {
        *u = u.max(prev + gap);
        prev = *u;
    }
    // ... the backward pass at least `gap` before its successor (and before 1).
    let mut next = 1.0;
    for u in interior.iter_mut().rev() {
        *u = u.min(next - gap);
        next = *u;
    }
    let mut knots = Vec::with_capacity(m + 2 * (p + 1));
    knots.extend(std::iter::repeat_n(0.0, p + 1));
    knots.extend(interior);
    knots.extend(std::iter::repeat_n(1.0, p + 1));
    knots
}

/// Nodes of the piecewise linear feature function (eqs. 10–11): `(u_first, 0)`,
/// `(u^(p)_i, |q^(p)_i|^(1/p))`, `(u_last, 0)`.
pub(crate) fn feature_function(
    points: &PointSet,
    params: &[f64],
    p: usize,
    geodesic: bool,
) -> (Vec<f64>, Vec<f64>) {
    crate::with_dim!(points.dim(), |d| feature_function_dim(
        d, points, params, p, geodesic
    ))
}

fn feature_function_dim<D: Dim>(
    d: D,
    points: &PointSet,
    params: &[f64],
    p: usize,
    geodesic: bool,
) -> (Vec<f64>, Vec<f64>) {
    let dim = d.get();
    // Order 0, keeping only strictly increasing parameters (repeated points add nothing).
    let mut u: Vec<f64> = Vec::with_capacity(params.len());
    let mut q: Vec<f64> = Vec::with_capacity(params.len() * dim);
    for (i, &t) in params.iter().enumerate() {
        if u.last().is_none_or(|&last| t > last) {
            u.push(t);
            q.extend_from_slice(points.get(i));
        }
    }
    // Each order is computed in place: entry i of order k+1 only reads entries i and i+1 of
    // order k, so walking i upwards never reads an overwritten value.
    let mut base = if geodesic { q.clone() } else { Vec::new() };
    let mut h = vec![0.0; dim];
    let mut len = u.len();
    for _ in 0..p {
        if len < 2 {
            break;
        }
        for i in 0..len - 1 {
            let du = u[i + 1] - u[i];
            let (lo, hi) = q.split_at_mut((i + 1) * dim);
            let (a, b) = (&mut lo[i * dim..], &hi[..dim]);
            if geodesic {
                let (bl, bh) = base.split_at_mut((i + 1) * dim);
                let (bi, bj) = (&mut bl[i * dim..], &bh[..dim]);
                for k in 0..dim {
                    h[k] = bi[k] + bj[k];
                }
                normalize(d, &mut h);
                // proj_h b − proj_h a = (b − a) − ((b − a)·h) h
                let mut along = 0.0;
                for k in 0..dim {
                    along += (b[k] - a[k]) * h[k];
                }
                for k in 0..dim {
                    a[k] = (b[k] - a[k] - along * h[k]) / du;
                }
                bi[..dim].copy_from_slice(&h[..dim]);
            } else {
                for k in 0..dim {
                    a[k] = (b[k] - a[k]) / du;
                }
            }
            u[i] = 0.5 * (u[i] + u[i + 1]);
        }
        len -= 1;
    }
    let first = params[0];
    let last = params[params.len() - 1];
    let mut nodes_u = vec![first];
    let mut nodes_f = vec![0.0];
    let inv_p = 1.0 / p as f64;
    for i in 0..len.min(u.len()) {
        let v = &q[i * dim..(i + 1) * dim];
        let norm = dot(d, v, v).sqrt();
        let mag = match p {
            1 => norm,
            2 => norm.sqrt(),
            3 => norm.cbrt(),
            _ => norm.powf(inv_p),
        };
        if u[i] > *nodes_u.last().unwrap() && u[i] < last && mag.is_finite() {
            nodes_u.push(u[i]);
            nodes_f.push(mag);
        }
    }
    nodes_u.push(last);
    nodes_f.push(0.0);
    (nodes_u, nodes_f)
}

/// Knots at equal levels of the CDF of the piecewise linear function through the nodes
/// (eqs. 12–17): `m - 1` interior knots with `F(t_i) = i F_max / m`. `None` when the function
/// is identically zero (the caller falls back to uniform knots).
fn invert_cdf(nodes_u: &[f64], nodes_f: &[f64], m: usize) -> Option<Vec<f64>> {
    let segs = nodes_u.len() - 1;
    let mut cdf = Vec::with_capacity(nodes_u.len());
    cdf.push(0.0);
    for s in 0..segs {
        let w = nodes_u[s + 1] - nodes_u[s];
        cdf.push(cdf[s] + 0.5 * w * (nodes_f[s] + nodes_f[s + 1]));
    }
    let total = cdf[segs];
    if total <= 0.0 || !total.is_finite() {
        return None;
    }
    let mut out = Vec::with_capacity(m.saturating_sub(1));
    let mut s = 0;
    for i in 1..m {
        let level = total * i as f64 / m as f64;
        while s + 1 < segs && cdf[s + 1] < level {
            s += 1;
        }
        let (xa, w) = (nodes_u[s], nodes_u[s + 1] - nodes_u[s]);
        let (fa, fb) = (nodes_f[s], nodes_f[s + 1]);
        let r = (level - cdf[s]).max(0.0);
        // F(xa + x) - F(xa) = fa x + (fb - fa) x^2 / (2 w); stable root of the quadratic.
        let slope = (fb - fa) / w;
        let disc = (fa * fa + 2.0 * slope * r).max(0.0);
        let denom = fa + disc.sqrt();
        let x = if denom > 0.0 { 2.0 * r / denom } else { 0.0 };
        out.push(xa + x.clamp(0.0, w));
    }
    Some(out)
}

/// Initial control points: the data polyline, SLERP between neighbours, at the Greville
/// abscissae `(u_{i+1} + ... + u_{i+p}) / p` of the knots (paper §4.3, read as in METHOD.md).
///
/// # Errors
/// [`SphereError::Antipodal`] when neighbouring data points are antipodal.
pub fn greville_control_points(
    points: &PointSet,
    params: &[f64],
    knots: &[f64],
    p: usize,
) -> Result<PointSet, SphereError> {
    let n_ctrl = knots.len() - p - 1;
    let dim = points.dim();
    let mut coords = Vec::with_capacity(n_ctrl * dim);
    let last = params.len() - 1;
    for i in 0..n_ctrl {
        let xi = knots[i + 1..=i + p].iter().sum::<f64>() / p as f64;
        let j = params.partition_point(|&t| t <= xi);
        if j == 0 {
            coords.extend_from_slice(points.get(0));
        } else if j > last {
            coords.extend_from_slice(points.get(last));
        } else {
            let (ta, tb) = (params[j - 1], params[j]);
            let f = if tb > ta { (xi - ta) / (tb - ta) } else { 0.0 };
            let v =
                slerp(points.get(j - 1), points.get(j), f).map_err(|_| SphereError::Antipodal {
                    index: j,
                    angle_rad: Arc::between(Dynamic(dim), points.get(j - 1), points.get(j)).theta,
                })?;
            coords.extend_from_slice(&v);
        }
    }
    Ok(PointSet::from_flat_unchecked(dim, coords))
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    fn great_circle(n: usize, step: f64) -> PointSet {
        let rows: Vec<Vec<f64>> = (0..n)
            .map(|i| {
                let a = step * i as f64;
                vec![a.cos(), a.sin() * 0.6, a.sin() * 0.8]
            })
            .collect();
        PointSet::try_from_rows(&rows).unwrap()
    }

    #[test]
    fn chord_parameters_of_equal_steps_are_uniform() {
        let pts = great_circle(5, 0.1);
        let t = parameters(&pts, Parameterization::Chord).unwrap();
        for (i, x) in t.iter().enumerate() {
            assert_relative_eq!(*x, i as f64 / 4.0, epsilon = 1e-14);
        }
    }

    #[test]
    fn higher_geodesic_differences_vanish_on_a_great_circle() {
        let pts = great_circle(12, 0.05);
        let t = parameters(&pts, Parameterization::Chord).unwrap();
        let (_, f) = feature_function(&pts, &t, 2, true);
        assert!(f.iter().all(|x| *x < 1e-6), "{f:?}");
        let (_, fe) = feature_function(&pts, &t, 2, false);
        assert!(fe[1..fe.len() - 1].iter().all(|x| *x > 0.1), "{fe:?}");
    }

    #[test]
    fn cdf_inversion_of_a_constant_function_is_uniform() {
        let k = invert_cdf(&[0.0, 0.5, 1.0], &[2.0, 2.0, 2.0], 4).unwrap();
        for (i, x) in k.iter().enumerate() {
            assert_relative_eq!(*x, (i + 1) as f64 / 4.0, epsilon = 1e-14);
        }
        // A ramp f(u) = u has F = u^2/2: levels F_max i/m sit at sqrt(i/m).
        let k = invert_cdf(&[0.0, 1.0], &[0.0, 1.0], 4).unwrap();
        for (i, x) in k.iter().enumerate() {
            assert_relative_eq!(*x, ((i + 1) as f64 / 4.0).sqrt(), epsilon = 1e-14);
        }
    }

    #[test]
    fn knots_are_clamped_and_strictly_increasing_inside() {
        let pts = great_circle(20, 0.05);
        let t = parameters(&pts, Parameterization::Chord).unwrap();
        for placement in [
            KnotPlacement::Uniform,
            KnotPlacement::Euclidean,
            KnotPlacement::Geodesic,
        ] {
            let k = place_knots(&pts, &t, 8, 3, placement).unwrap();
            assert_eq!(k.len(), 12);
            assert_eq!(&k[..4], &[0.0; 4]);
            assert_eq!(&k[8..], &[1.0; 4]);
            assert!(
                k[3..9].windows(2).all(|w| w[1] > w[0]),
                "{placement:?} {k:?}"
            );
        }
    }

    #[test]
    fn given_parameters_are_checked_and_normalised() {
        assert_eq!(
            normalize_parameters(&[10.0, 15.0, 20.0], 3).unwrap(),
            vec![0.0, 0.5, 1.0]
        );
        let e = normalize_parameters(&[1.0, 3.0, 2.0], 3).unwrap_err();
        assert!(e.to_string().contains("parameter 2"), "{e}");
        assert!(normalize_parameters(&[1.0, 2.0], 3).is_err());
        assert!(normalize_parameters(&[1.0, 1.0], 2).is_err());
    }
}
