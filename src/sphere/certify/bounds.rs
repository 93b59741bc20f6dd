//! Proven bounds on what a curve does between two of its samples: the speed bound of a SLERP
//! triangle (de Boor or de Casteljau), the spherical-ellipse bound on how far a curve piece can
//! stray from its chord, and the largest distance from a great-circle arc to another arc.
//!
//! These are the building blocks of the certified two-way distance ([`super::two_way`]) and of
//! the certified dense sampling ([`super::dense`]); the proofs are in `docs/certified-distance.md`.
//!
//! All angles are radians on the unit sphere S^n (any n); nothing here knows about metres.

use crate::sphere::geometry::arc::ArcFrame;
use crate::sphere::geometry::point::{
    angle_between, dot, sinc_series, Dim, Dynamic, SERIES_ANGLE_MAX_RAD,
};
use smallvec::{smallvec, SmallVec};

/// Added to every proven bound: the bounds hold in exact arithmetic, and the curve's own
/// evaluation, the distances and the trigonometry each round at about 1e-16 rad; 1e-12 rad
/// (6 µm on the Earth) covers their sum with a wide margin.
pub const ROUNDING_SLACK_RAD: f64 = 1e-12;

/// Relative slack on speed bounds for the same reason (a bound computed with rounding can land
/// a few ulps below the true supremum). Kept near rounding: the ellipse bound grows like the
/// square root of the length excess, so a looser slack would cost real precision.
const SPEED_SLACK: f64 = 4e-15;

/// Absolute slack taken off a measured chord (radians) in [`ellipse_deviation`], for the
/// rounding of the two curve points and of their angle.
const CHORD_SLACK_RAD: f64 = 1e-15;

/// Arcs whose bound on the angle between the two SLERPed points reaches this are not bounded
/// (the SLERP weights blow up near pi): the caller subdivides instead.
const THETA_LIMIT_RAD: f64 = std::f64::consts::PI - 1e-3;

/// `sin(x) / x` for `0 <= x < pi`: the series of [`crate::sphere::geometry`] up to its range
/// (exact to rounding there, and a tenth of libm's cost: the bounds below take several per
/// node of a SLERP triangle, whose angles are nearly always small), libm beyond.
#[inline]
fn sinc(x: f64) -> f64 {
    if x <= SERIES_ANGLE_MAX_RAD {
        sinc_series(x)
    } else {
        x.sin() / x
    }
}

/// `sin((1 - alpha) theta) / sin theta`, the first SLERP weight, for theta in [0, pi).
#[inline]
fn weight0(alpha: f64, theta: f64) -> f64 {
    if theta < 1e-8 {
        1.0 - alpha
    } else {
        // = (1 - alpha) sinc((1 - alpha) theta) / sinc(theta).
        (1.0 - alpha) * sinc((1.0 - alpha) * theta) / sinc(theta)
    }
}

/// One node of a SLERP triangle: its alpha at both ends of the parameter interval and the
/// alpha's slope `d alpha / dt` (alpha is affine in t in de Boor and de Casteljau).
#[derive(Clone, Copy, Debug)]
pub(crate) struct NodeAlpha {
    pub at_start: f64,
    pub at_end: f64,
    pub slope: f64,
}

/// [`triangle_speed_bound`] of a Bézier curve on `control` (de Casteljau: alpha = t, slope 1)
/// over `t in [a, b]`, `0 <= a <= b <= 1`.
pub(crate) fn bezier_speed_bound(
    dim: usize,
    control: &[f64],
    (a, b): (f64, f64),
    scratch: &mut Vec<f64>,
) -> f64 {
    let alpha = |_, _| NodeAlpha {
        at_start: a,
        at_end: b,
        slope: 1.0,
    };
    triangle_speed_bound(dim, control, alpha, b - a, scratch)
}

/// An upper bound of the speed |dC/dt| (radians per unit of t) over `t in [a, b]` of the apex of
/// a SLERP triangle on the `p + 1` points `control` (flat, `dim` per point): level r, node j is
/// `SLERP(node(r-1, j-1), node(r-1, j), alpha(r, j, t))`, as in de Boor's algorithm (B-splines)
/// and de Casteljau's (Bézier segments).
///
/// Per node, with S the speed bounds of the two nodes below and Theta a bound of the angle
/// between them over the interval (their angle at `a` plus (S_left + S_right)(b - a)):
/// `S_node <= w0(alpha_min, Theta) S_left + w1(alpha_max, Theta) S_right + Theta |alpha'|`.
/// (The derivative of SLERP along an end point is a Jacobi field whose length is at most the
/// SLERP weight of that end; along alpha it is the arc's angle.) Level 0 points do not move.
///
/// Returns infinity when an angle bound comes near pi (the caller then subdivides).
pub(crate) fn triangle_speed_bound(
    dim: usize,
    control: &[f64],
    alpha: impl Fn(usize, usize) -> NodeAlpha,
    width: f64,
    scratch: &mut Vec<f64>,
) -> f64 {
    let m = control.len() / dim;
    let p = m - 1;
    scratch.clear();
    scratch.extend_from_slice(control);
    let mut speed = [0.0f64; crate::sphere::curve::bspline::MAX_DEGREE + 2];
    let d = Dynamic(dim);
    let mut tmp_store: SmallVec<[f64; 16]> = smallvec![0.0; dim];
    let tmp: &mut [f64] = &mut tmp_store;
    for r in 1..=p {
        for j in (r..=p).rev() {
            let (left, right) = scratch.split_at_mut(j * dim);
            let a = &left[(j - 1) * dim..j * dim];
            let b = &mut right[..dim];
            let arc = crate::sphere::geometry::point::Arc::between(d, a, b);
            let theta = arc.theta + (speed[j - 1] + speed[j]) * width;
            if theta >= THETA_LIMIT_RAD || !theta.is_finite() {
                return f64::INFINITY;
            }
            let na = alpha(r, j);
            let lo = na.at_start.min(na.at_end).clamp(0.0, 1.0);
            let hi = na.at_start.max(na.at_end).clamp(0.0, 1.0);
            let w0 = weight0(lo, theta);
            let w1 = weight0(1.0 - hi, theta);
            speed[j] = w0 * speed[j - 1] + w1 * speed[j] + theta * na.slope.abs();
            // The node's position at the start of the interval, for the next level's angles.
            let s = na.at_start.clamp(0.0, 1.0);
            let (v0, v1) = arc.weights_unit(s);
            for c in 0..dim {
                tmp[c] = v0 * a[c] + v1 * b[c];
            }
            let n = dot(d, tmp, tmp).sqrt();
            for c in 0..dim {
                b[c] = tmp[c] / n;
            }
        }
    }
    speed[p] * (1.0 + SPEED_SLACK)
}

/// Largest angle between two SLERPed nodes for which [`triangle_acceleration_bound`] gives a
/// finite bound: its constants use `sin(theta) >= 2 theta / pi`, true up to pi / 2.
const ACCEL_THETA_LIMIT_RAD: f64 = std::f64::consts::FRAC_PI_2;

/// Relative slack on acceleration bounds (rounding, as [`SPEED_SLACK`]): the deviation bound
/// grows only linearly with it, so it can be generous.
const ACCEL_SLACK: f64 = 1e-9;

/// An upper bound of |C''(t)| in the ambient space R^(n+1) over `t in [a, b]` of the apex of a
/// SLERP triangle (the same triangle as [`triangle_speed_bound`], `width = b - a`), or infinity
/// when an angle between two nodes may pass pi / 2 on the interval.
///
/// A node is `x = g(alpha, theta) x_l + f(alpha, theta) x_r` with `f = sin(alpha theta) / sin
/// theta`, `g = f(1 - alpha, theta)` and theta the angle between the nodes below. Differentiating
/// twice (alpha is affine in t, slope m) and bounding each term (derivations in
/// `docs/certified-distance.md`, "Acceleration bound"), with V, A the speed and acceleration
/// bounds of the nodes below, Theta the angle bound over the interval, S = Theta / sin Theta,
/// `V_theta = V_l + V_r` (the angle is 1-Lipschitz in each end) and
/// `Q = V_theta^2 + 2 (1 - cos Theta) V_l V_r`:
///
/// `A_x <= Theta^2 m^2 + (10/3) m V_theta Theta S^2 + (3/4) V_theta^2 (S + 2 S^3 / 3)
///         + (1/4)(Theta S^2 (A_l + A_r) + S^3 Q) + 2 (V_l + V_r)(S m + 0.13 Theta S^2 V_theta)
///         + w0 A_l + w1 A_r`
///
/// For a straight de Boor step (Theta -> 0) this is the affine `(1 - alpha) A_l + alpha A_r +
/// 2 m (V_l + V_r)` plus the terms of the sphere's curvature. Level 0 points do not move.
pub(crate) fn triangle_acceleration_bound(
    dim: usize,
    control: &[f64],
    alpha: impl Fn(usize, usize) -> NodeAlpha,
    width: f64,
    scratch: &mut Vec<f64>,
) -> f64 {
    crate::with_dim!(dim, |d| triangle_acceleration_bound_in(
        d, control, &alpha, width, scratch
    ))
}

/// [`triangle_acceleration_bound`] in dimension `d`.
fn triangle_acceleration_bound_in<D: Dim>(
    d: D,
    control: &[f64],
    alpha: &impl Fn(usize, usize) -> NodeAlpha,
    width: f64,
    scratch: &mut Vec<f64>,
) -> f64 {
    let dim = d.get();
    let m_pts = control.len() / dim;
    let p = m_pts - 1;
    scratch.clear();
    scratch.extend_from_slice(control);
    let mut speed = [0.0f64; crate::sphere::curve::bspline::MAX_DEGREE + 2];
    let mut accel = [0.0f64; crate::sphere::curve::bspline::MAX_DEGREE + 2];
    let mut tmp_store: SmallVec<[f64; 16]> = smallvec![0.0; dim];
    let tmp: &mut [f64] = &mut tmp_store;
    for r in 1..=p {
        for j in (r..=p).rev() {
            let (left, right) = scratch.split_at_mut(j * dim);
            let a = &left[(j - 1) * dim..j * dim];
            let b = &mut right[..dim];
            let (va, vb, aa, ab) = (speed[j - 1], speed[j], accel[j - 1], accel[j]);
            let v_theta = va + vb;
            let arc = crate::sphere::geometry::point::Arc::between(d, a, b);
            let theta = arc.theta + v_theta * width;
            if theta >= ACCEL_THETA_LIMIT_RAD || !theta.is_finite() {
                return f64::INFINITY;
            }
            let na = alpha(r, j);
            let lo = na.at_start.min(na.at_end).clamp(0.0, 1.0);
            let hi = na.at_start.max(na.at_end).clamp(0.0, 1.0);
            let w0 = weight0(lo, theta);
            let w1 = weight0(1.0 - hi, theta);
            let m = na.slope.abs();
            // theta / sin theta, and 1 - cos theta = 2 sin^2(theta / 2), from the series.
            let s = 1.0 / sinc(theta);
            let s2 = s * s;
            let s3 = s2 * s;
            let half_sin = 0.5 * theta * sinc(0.5 * theta);
            let one_minus_cos = 2.0 * half_sin * half_sin;
            let q = v_theta * v_theta + 2.0 * one_minus_cos * va * vb;
            accel[j] = theta * theta * m * m
                + (10.0 / 3.0) * m * v_theta * theta * s2
                + 0.75 * v_theta * v_theta * (s + 2.0 * s3 / 3.0)
                + 0.25 * (theta * s2 * (aa + ab) + s3 * q)
                + 2.0 * (va + vb) * (s * m + 0.13 * theta * s2 * v_theta)
                + w0 * aa
                + w1 * ab;
            speed[j] = w0 * va + w1 * vb + theta * m;
            let st = na.at_start.clamp(0.0, 1.0);
            let (v0, v1) = arc.weights_unit(st);
            for c in 0..dim {
                tmp[c] = v0 * a[c] + v1 * b[c];
            }
            let n = dot(d, tmp, tmp).sqrt();
            for c in 0..dim {
                b[c] = tmp[c] / n;
            }
        }
    }
    accel[p] * (1.0 + ACCEL_SLACK)
}

/// How far the curve piece over a parameter interval of `width`, whose ambient acceleration
/// is at most `accel` and whose ends are `chord` apart, can be from the great-circle arc
/// joining its ends (both ways), or infinity.
///
/// The piece is within `accel width^2 / 8` (Euclidean) of the straight segment between its
/// ends at the same parameter (linear interpolation's error, from the Green's function of the
/// second derivative), and the segment's point is within `1 - cos(chord / 2)` of its radial
/// projection on the arc; the projection runs over the whole arc, so the bound holds both ways.
/// Unlike [`ellipse_deviation`] it falls with the square of the width, not its 3/2 power.
pub fn acceleration_deviation(accel: f64, width: f64, chord: f64) -> f64 {
    if !(accel.is_finite() && chord < std::f64::consts::FRAC_PI_2) {
        return f64::INFINITY;
    }
    let e = accel * width * width / 8.0 + 2.0 * (chord / 4.0).sin().powi(2);
    if e >= 2.0 {
        return std::f64::consts::PI;
    }
    2.0 * (e / 2.0).asin() + ROUNDING_SLACK_RAD
}

/// How far a curve piece of length at most `length` whose ends are `chord` apart can be from
/// the great-circle arc joining its ends (both ways: every curve point is within this of the
/// arc, and every arc point within this of the curve).
///
/// Every point x of the piece has d(x, F1) + d(x, F2) <= length (F1, F2 the ends), so it lies
/// in a spherical ellipse: its distance h to the great circle through the ends satisfies
/// `cos h >= cos(length/2) / cos(chord/2)`, and its foot on that circle lies at most
/// `(length - chord) / 2` beyond the arc; the bound is h + that overhang. The other direction
/// holds because the curve's foot point on the arc moves continuously from one end to the
/// other. Infinity when `length >= pi`.
pub fn ellipse_deviation(length: f64, chord: f64) -> f64 {
    if length.is_nan() || length >= std::f64::consts::PI {
        return f64::INFINITY;
    }
    let length = length * (1.0 + SPEED_SLACK);
    let chord = (chord - CHORD_SLACK_RAD).max(0.0).min(length);
    let excess = length - chord;
    // sin^2(h/2) = sin((l + c)/4) sin((l - c)/4) / cos(c/2), a cancellation-free form.
    let s2 = ((length + chord) / 4.0).sin() * (excess / 4.0).sin() / (chord / 2.0).cos();
    let h = 2.0 * s2.max(0.0).sqrt().min(1.0).asin();
    h + 0.5 * excess + ROUNDING_SLACK_RAD
}

/// An upper bound of the largest distance from a point of the minor great-circle arc `y0`–`y1`
/// to the arc of `frame` (the maximum, over the first arc, of the distance to the second).
///
/// The first arc is cut where it crosses the great circles perpendicular to the second arc at
/// its ends; on each piece the distance is either to the second arc's great circle (whose sine
/// is a sinusoid along the arc, at most its larger end value over cos(chord/2)) or to one end
/// point (at most its larger end value). So the maximum over the cut points of the distance,
/// pushed through `asin(sin(.) / cos(chord/2))`, bounds it. Falls back to the Lipschitz bound
/// when distances reach 1 rad.
pub(crate) fn arc_to_arc_sup(y0: &[f64], y1: &[f64], frame: &ArcFrame) -> f64 {
    arc_to_arc_sup_attained(y0, y1, frame).0
}

/// [`arc_to_arc_sup`], and the largest distance to the second arc it measured at points of the
/// first (so attained: a lower bound of the maximum).
pub(crate) fn arc_to_arc_sup_attained(y0: &[f64], y1: &[f64], frame: &ArcFrame) -> (f64, f64) {
    let d = Dynamic(y0.len());
    let ends = (frame.distance_dyn(y0), frame.distance_dyn(y1));
    arc_to_arc_known(d, y0, y1, angle_between(y0, y1), ends, frame)
}

/// [`arc_to_arc_sup_attained`] with the first arc's angle `c` and its ends' distances to the
/// second arc already known, in dimension `d`, without allocation for up to 16 coordinates:
/// the closed-form two-way distance of a polyline calls it once per arc of the curve.
#[inline]
pub(crate) fn arc_to_arc_known<D: Dim>(
    d: D,
    y0: &[f64],
    y1: &[f64],
    c: f64,
    (d0, d1): (f64, f64),
    frame: &ArcFrame,
) -> (f64, f64) {
    let dim = d.get();
    let ends = d0.max(d1);
    if c < 1e-12 {
        return (ends + c + ROUNDING_SLACK_RAD, ends);
    }
    let lipschitz = 0.5 * (d0 + d1 + c) + ROUNDING_SLACK_RAD;
    if frame.degenerate() {
        // The second "arc" is a point: distance to a point along an arc is at most its larger
        // end value while below pi/2.
        let bound = if ends < 1.0 {
            ends + ROUNDING_SLACK_RAD
        } else {
            lipschitz
        };
        return (bound, ends);
    }
    let mut stack = [0.0; 48];
    let mut heap = Vec::new();
    let buf: &mut [f64] = if dim <= 16 {
        &mut stack[..3 * dim]
    } else {
        heap.resize(3 * dim, 0.0);
        &mut heap
    };
    let (w, rest) = buf.split_at_mut(dim);
    let (m, y) = rest.split_at_mut(dim);
    // Unit tangent of the first arc at y0: y(s) = cos s y0 + sin s w.
    let cos = dot(d, y0, y1);
    for k in 0..dim {
        w[k] = y1[k] - cos * y0[k];
    }
    let n = dot(d, w, w).sqrt();
    if n.is_nan() || n <= 0.0 {
        return (lipschitz, ends);
    }
    w.iter_mut().for_each(|x| *x /= n);
    let mut worst = ends;
    let (sin_t, cos_t) = (frame.sin_theta(), frame.cos_theta());
    // Normals of the two perpendicular great circles: e2 (at the start), -sin e1 + cos e2.
    for which in 0..2 {
        for k in 0..dim {
            m[k] = if which == 0 {
                frame.e2[k]
            } else {
                -sin_t * frame.e1[k] + cos_t * frame.e2[k]
            };
        }
        let (g0, g_end) = (dot(d, m, y0), dot(d, m, y1));
        // m . y(s) is a sinusoid in s: on an arc shorter than pi it keeps its sign between
        // ends of the same sign, so the arc does not cross that circle (the usual case for a
        // curve running alongside the arc: no trigonometry).
        if g0 * g_end > 0.0 && c < std::f64::consts::PI {
            continue;
        }
        let g1 = dot(d, m, w);
        // g0 cos s + g1 sin s = 0.
        let s0 = (-g0).atan2(g1);
        for k in -2..=2 {
            let s = s0 + k as f64 * std::f64::consts::PI;
            if s > 0.0 && s < c {
                let (ss, cs) = s.sin_cos();
                for x in 0..dim {
                    y[x] = cs * y0[x] + ss * w[x];
                }
                worst = worst.max(frame.distance_dyn(y));
            }
        }
    }
    if worst >= 1.0 {
        return (lipschitz, worst);
    }
    let bound = asin_of_sine_over_cos_half(worst, c) + ROUNDING_SLACK_RAD;
    (bound.min(lipschitz), worst)
}

/// asin(sin(a) / cos(c / 2)) (at most pi/2), with the series of [`crate::sphere::geometry`]
/// where the angles are small (the usual case: a curve within a tolerance of a short arc),
/// libm beyond; exact to rounding either way.
#[inline]
fn asin_of_sine_over_cos_half(a: f64, c: f64) -> f64 {
    use crate::sphere::geometry::point::{angle_from_sine, sinc_series, SERIES_ANGLE_MAX_RAD};
    let sin_a = if a <= SERIES_ANGLE_MAX_RAD {
        a * sinc_series(a)
    } else {
        a.sin()
    };
    let quarter = 0.25 * c;
    let cos_half = if quarter <= SERIES_ANGLE_MAX_RAD {
        // cos(c / 2) = 1 - 2 sin^2(c / 4).
        let s = quarter * sinc_series(quarter);
        1.0 - 2.0 * s * s
    } else {
        (0.5 * c).cos()
    };
    angle_from_sine((sin_a / cos_half).min(1.0))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sphere::geometry::arc::distance_to_arc;

    fn ll(lon: f64, lat: f64) -> Vec<f64> {
        let (lo, la) = (lon.to_radians(), lat.to_radians());
        vec![la.cos() * lo.cos(), la.cos() * lo.sin(), la.sin()]
    }

    #[test]
    fn ellipse_bound_holds_for_a_bent_path() {
        // A path F1 -> X -> F2 of length d(F1,X) + d(X,F2): X must be within the bound.
        for &(lat, half) in &[(0.01, 0.5), (0.2, 0.3), (1e-5, 0.01), (3.0, 5.0)] {
            let (f1, f2, x) = (ll(-half, 0.0), ll(half, 0.0), ll(0.0, lat));
            let length = angle_between(&f1, &x) + angle_between(&x, &f2);
            let chord = angle_between(&f1, &f2);
            let dev = distance_to_arc(&x, &f1, &f2);
            let b = ellipse_deviation(length, chord);
            assert!(b >= dev, "{b} < {dev}");
            assert!(b <= dev + 0.5 * (length - chord) + 1e-9, "{b} vs {dev}");
        }
        // A straight path has no deviation.
        assert!(ellipse_deviation(0.3, 0.3) < 3e-8);
        assert!(ellipse_deviation(1e-4, 1e-4) < 1e-9);
    }

    #[test]
    fn arc_to_arc_sup_matches_dense_sampling() {
        let cases = [
            (ll(0.0, 0.1), ll(1.0, 0.2), ll(-0.5, 0.0), ll(1.5, 0.0)),
            (ll(-1.0, 0.05), ll(2.0, 0.3), ll(0.0, 0.0), ll(1.0, 0.0)),
            (ll(0.2, -0.3), ll(0.4, 0.4), ll(0.0, 0.0), ll(1.0, 0.1)),
            (ll(0.0, 1.0), ll(0.0, 1.0), ll(0.0, 0.0), ll(1.0, 0.0)),
        ];
        for (y0, y1, a, b) in cases {
            let frame = ArcFrame::new(Dynamic(3), &a, &b);
            let bound = arc_to_arc_sup(&y0, &y1, &frame);
            let mut brute: f64 = 0.0;
            for i in 0..=20_000 {
                let y =
                    crate::sphere::geometry::point::slerp(&y0, &y1, i as f64 / 20_000.0).unwrap();
                brute = brute.max(distance_to_arc(&y, &a, &b));
            }
            assert!(bound >= brute, "{bound} < {brute}");
            assert!(bound <= brute * 1.001 + 1e-10, "{bound} vs {brute}");
        }
    }

    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        /// The acceleration bound is above second differences of the curve anywhere in the
        /// interval, and the chord bound built on it above the distance of curve points from
        /// the chord; it is not loose by orders of magnitude on smooth curves.
        #[test]
        fn acceleration_bound_is_above_second_differences(
            p in 1usize..=5,
            n in 6usize..14,
            scale in 0.0005f64..60.0,
            wave in 0.0f64..0.6,
            seed in 0u64..1000,
            at in 0.0f64..1.0,
            frac in 0.01f64..1.0,
        ) {
            use crate::sphere::{PointSet, SphericalBSpline};
            use crate::sphere::geometry::arc::distance_to_arc;
            let rows: Vec<Vec<f64>> = (0..n)
                .map(|i| {
                    let jitter = ((i as u64 * 7919 + seed * 104_729) % 1000) as f64 / 1000.0 - 0.5;
                    ll(scale * i as f64 / n as f64, wave * scale * jitter)
                })
                .collect();
            let m = n - p;
            let mut k = vec![0.0; p + 1];
            k.extend((1..m).map(|i| i as f64 / m as f64));
            k.extend(std::iter::repeat_n(1.0, p + 1));
            let c = SphericalBSpline::try_new(p, k.clone(), PointSet::try_from_rows(&rows).unwrap()).unwrap();
            // An interval inside one span.
            let span = ((at * m as f64) as usize).min(m - 1);
            let (s0, s1) = (k[p + span], k[p + span + 1]);
            let w = frac * (s1 - s0);
            let u = s0 + at.fract() * (s1 - s0 - w);
            let v = u + w;
            let a = c.acceleration_bound(u, v);
            prop_assert!(a > 0.0);
            if a.is_finite() {
                let h = 0.01 * w;
                let ts: Vec<f64> = (0..=200).map(|i| u + h + (w - 2.0 * h) * i as f64 / 200.0).collect();
                let mut worst: f64 = 0.0;
                for &t in &ts {
                    let q = c.evaluate_many(&[t - h, t, t + h]);
                    let dd: f64 = (0..3).map(|d| (q.get(0)[d] - 2.0 * q.get(1)[d] + q.get(2)[d]) / (h * h)).map(|x| x * x).sum::<f64>().sqrt();
                    worst = worst.max(dd);
                }
                // Rounding in a second difference is about 1e-16 / h^2; truncation is h^2 |C^(4)| / 12.
                let noise = 1e-15 / (h * h);
                prop_assert!(worst <= a * 1.01 + noise, "second difference {worst} above the bound {a}");
                let pts = c.evaluate_many(&[u, v]);
                let chord = angle_between(pts.get(0), pts.get(1));
                let dev = acceleration_deviation(a, w, chord);
                let cs = c.evaluate_many(&ts);
                for i in 0..ts.len() {
                    let e = distance_to_arc(cs.get(i), pts.get(0), pts.get(1));
                    prop_assert!(e <= dev, "{e} > {dev}");
                }
            }
        }
    }
}
