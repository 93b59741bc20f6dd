//! Unit tests of the two-way distance: bounds against brute force, polylines, loops, errors.

use super::*;
use crate::sphere::geometry::arc::distance_to_arc;
use crate::sphere::SphericalBSpline;
use proptest::prelude::*;

#[test]
fn a_piece_straddling_its_knots_by_rounding_is_bounded_tightly() {
    // A polyline whose vertices are the data points, with the middle points' parameters
    // a hair outside the knots (as foot-point parameters come out): the middle piece
    // holds a sliver of each neighbouring segment, both arriving from inside the middle
    // segment (spikes), so the slivers' ends are the samples next to each other along the
    // arc. Its arc-to-curve bound once took the zero-width part of the arc at one of them
    // as being as far as the other: the segment's whole length.
    let rows = [
        ll(0.015, 0.0003),
        ll(0.01, 0.0),
        ll(0.02, 0.0),
        ll(0.015, -0.0003),
    ];
    let ctrl = PointSet::try_from_rows(&rows).unwrap();
    let knots = vec![0.0, 0.0, 1.0 / 3.0, 2.0 / 3.0, 1.0, 1.0];
    let s = SphericalBSpline::try_new(1, knots, ctrl.clone()).unwrap();
    let params = [0.0, 1.0 / 3.0 - 1e-9, 2.0 / 3.0 + 1e-9, 1.0];
    let tw = two_way_distance(&s, &ctrl, &params, &TwoWayOptions::default()).unwrap();
    // The curve is the polyline itself: zero, to the default precision (the segment is
    // 0.01 rad long).
    assert!(tw.upper_rad < 1e-7, "{:e}", tw.upper_rad);
}
fn ll(lon: f64, lat: f64) -> [f64; 3] {
    [lat.cos() * lon.cos(), lat.cos() * lon.sin(), lat.sin()]
}

/// A clamped spline of degree p on uniform knots through wavy control points.
fn spline(p: usize, n: usize, scale: f64, wave: f64, seed: u64) -> SphericalBSpline {
    let rows: Vec<[f64; 3]> = (0..n)
        .map(|i| {
            let a = scale * i as f64 / (n - 1) as f64;
            let s = ((i as u64 * 7919 + seed * 104_729) % 1000) as f64 / 1000.0 - 0.5;
            ll(a, wave * scale * s)
        })
        .collect();
    let m = n - p;
    let mut k = vec![0.0; p + 1];
    k.extend((1..m).map(|i| i as f64 / m as f64));
    k.extend(std::iter::repeat_n(1.0, p + 1));
    SphericalBSpline::try_new(p, k, PointSet::try_from_rows(&rows).unwrap()).unwrap()
}

/// The two-way distance by brute force: dense samples of every piece and every arc.
fn brute(c: &SphericalBSpline, q: &PointSet, t: &[f64], per: usize) -> f64 {
    let n = q.len();
    let mut worst: f64 = 0.0;
    for j in 0..n {
        worst = worst.max(angle_between(q.get(j), &c.evaluate(t[j])));
    }
    for j in 0..n - 1 {
        let (ta, tb) = (
            if j == 0 { 0.0 } else { t[j] },
            if j + 2 == n { 1.0 } else { t[j + 1] },
        );
        let ts: Vec<f64> = (0..=per)
            .map(|i| ta + (tb - ta) * i as f64 / per as f64)
            .collect();
        let cs = c.evaluate_many(&ts);
        let (a, b) = (q.get(j), q.get(j + 1));
        for p in cs.iter() {
            worst = worst.max(distance_to_arc(p, a, b));
        }
        for i in 0..=per {
            let x = crate::sphere::geometry::point::slerp(a, b, i as f64 / per as f64).unwrap();
            // The nearest sample, then the nearest curve point around it (golden section):
            // the nearest sample alone overstates the distance by up to a sample gap's
            // worth, which is more than the certified bound's slack when the curve passes
            // close to the arc.
            let (k, m) = cs.iter().map(|p| angle_between(&x, p)).enumerate().fold(
                (0, f64::INFINITY),
                |b, (k, m)| if m < b.1 { (k, m) } else { b },
            );
            let (mut lo, mut hi) = (ts[k.saturating_sub(1)], ts[(k + 1).min(per)]);
            let at = |u: f64| angle_between(&x, &c.evaluate(u));
            let g = 0.5 * (5f64.sqrt() - 1.0);
            for _ in 0..60 {
                let (u1, u2) = (hi - g * (hi - lo), lo + g * (hi - lo));
                if at(u1) < at(u2) {
                    hi = u2;
                } else {
                    lo = u1;
                }
            }
            worst = worst.max(m.min(at(0.5 * (lo + hi))));
        }
    }
    worst
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

#[test]
    fn certified_bound_is_above_brute_force_and_close(
        p in 1usize..=3,
        n_ctrl in 4usize..9,
        scale in 0.001f64..0.5,
        wave in 0.0f64..0.3,
        seed in 0u64..1000,
        n_pts in 3usize..9,
        noise in 0.0f64..0.05,
    ) {
        let c = spline(p, n_ctrl, scale, wave, seed);
        // Points near the curve at sorted parameters, pushed off by `noise`.
        let t: Vec<f64> = (0..n_pts).map(|i| i as f64 / (n_pts - 1) as f64).collect();
        let rows: Vec<Vec<f64>> = t.iter().enumerate().map(|(i, &u)| {
            let on = c.evaluate(u);
            let off = noise * scale * (((i as u64 + seed) % 7) as f64 / 7.0 - 0.5);
            let mut v = on.clone();
            v[2] += off;
            let nrm = v.iter().map(|x| x * x).sum::<f64>().sqrt();
            v.iter().map(|x| x / nrm).collect()
        }).collect();
        let q = PointSet::try_from_rows(&rows).unwrap();
        let prec = 1e-3 * scale;
        let d = two_way_distance(&c, &q, &t, &TwoWayOptions::default().with_precision_rad(prec)).unwrap();
        let b = brute(&c, &q, &t, 800);
        prop_assert!(d.upper_rad >= b * (1.0 - 1e-9) - 1e-12, "certified {} < brute {}", d.upper_rad, b);
        prop_assert!(d.upper_rad <= b + 2.0 * prec + 1e-9 * scale, "certified {} far above brute {}", d.upper_rad, b);
        prop_assert!(d.lower_rad <= d.upper_rad);
        prop_assert!(!d.budget_exhausted);
    }
}

/// A curve seen only through the general interface (no [`SphericalCurve::as_polyline`]).
struct General<'a>(&'a SphericalBSpline);

impl SphericalCurve for General<'_> {
    fn dim(&self) -> usize {
        self.0.dim()
    }
    fn domain(&self) -> (f64, f64) {
        self.0.domain()
    }
    fn evaluate_many(&self, ts: &[f64]) -> PointSet {
        self.0.evaluate_many(ts)
    }
    fn speed_bound(&self, t0: f64, t1: f64) -> f64 {
        SphericalCurve::speed_bound(self.0, t0, t1)
    }
    fn breaks(&self) -> Vec<f64> {
        SphericalCurve::breaks(self.0)
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// The closed form for polylines agrees with the general subdivision, measuring and
    /// deciding, with the points' parameters anywhere in the domain (the first and last
    /// inside it too).
    #[test]
    fn the_polyline_closed_form_agrees_with_subdivision(
        n_ctrl in 2usize..12,
        scale in 0.0005f64..0.5,
        wave in 0.0f64..0.3,
        seed in 0u64..1000,
        n_pts in 2usize..14,
        noise in 0.0f64..0.05,
        start in 0.0f64..0.2,
        end in 0.8f64..1.0,
        level in 0.2f64..2.0,
    ) {
        let c = spline(1, n_ctrl, scale, wave, seed);
        let t: Vec<f64> = (0..n_pts)
            .map(|i| {
                let u = i as f64 / (n_pts - 1) as f64;
                let jitter = ((i as u64 * 31 + seed) % 11) as f64 / 11.0 - 0.5;
                (start + (end - start) * u + 0.3 * jitter / n_pts as f64).clamp(0.0, 1.0)
            })
            .scan(0.0f64, |m, u| { *m = m.max(u); Some(*m) })
            .collect();
        let rows: Vec<Vec<f64>> = t.iter().enumerate().map(|(i, &u)| {
            let mut v = c.evaluate(u);
            v[2] += noise * scale * (((i as u64 * 3 + seed) % 7) as f64 / 7.0 - 0.5);
            let nrm = v.iter().map(|x| x * x).sum::<f64>().sqrt();
            v.iter().map(|x| x / nrm).collect()
        }).collect();
        let q = PointSet::try_from_rows(&rows).unwrap();
        prop_assert!(c.as_polyline().is_some());
        let prec = 1e-3 * scale;
        let o = TwoWayOptions::default().with_precision_rad(prec);
        let fast = two_way_distance(&c, &q, &t, &o).unwrap();
        let slow = two_way_distance(&General(&c), &q, &t, &o).unwrap();
        prop_assert!(fast.upper_rad >= slow.lower_rad - 1e-12, "{} < {}", fast.upper_rad, slow.lower_rad);
        prop_assert!(slow.upper_rad >= fast.lower_rad - 1e-12, "{} < {}", slow.upper_rad, fast.lower_rad);
        prop_assert!(fast.upper_rad - fast.lower_rad <= prec + 1e-12);
        prop_assert!((fast.curve_length_rad - slow.curve_length_rad).abs() <= 1e-9 * scale);
        // Deciding at a level away from the distance gives the same answer.
        let at = level * slow.upper_rad.max(1e-6 * scale);
        if (at - slow.upper_rad).abs() > 2.0 * prec {
            let od = o.clone().deciding(at);
            let fd = two_way_distance(&c, &q, &t, &od).unwrap();
            let sd = two_way_distance(&General(&c), &q, &t, &od).unwrap();
            prop_assert_eq!(fd.exceeded, sd.exceeded);
            prop_assert_eq!(fd.exceeded, slow.upper_rad > at);
            if !fd.exceeded {
                prop_assert!(fd.upper_rad <= at.max(slow.upper_rad + prec) + 1e-12);
            }
        }
    }
}

#[test]
fn a_polyline_fitted_by_itself_is_at_distance_zero() {
    let rows: Vec<[f64; 3]> = (0..6)
        .map(|i| ll(0.01 * i as f64, 0.003 * ((i * i) % 5) as f64))
        .collect();
    let q = PointSet::try_from_rows(&rows).unwrap();
    let k = vec![0.0, 0.0, 0.2, 0.4, 0.6, 0.8, 1.0, 1.0];
    let c = SphericalBSpline::try_new(1, k, q.clone()).unwrap();
    let t = [0.0, 0.2, 0.4, 0.6, 0.8, 1.0];
    let d = two_way_distance(
        &c,
        &q,
        &t,
        &TwoWayOptions::default().with_precision_rad(1e-9),
    )
    .unwrap();
    assert!(d.upper_rad < 1e-8, "{}", d.upper_rad);
    assert!(d.evaluations < 10_000, "{}", d.evaluations);
    let len = polyline_length(&q);
    assert!((d.curve_length_rad - len).abs() < 1e-12 * len.max(1.0) + 1e-14);
}

#[test]
fn a_loop_of_the_curve_is_not_covered_by_another_stretch() {
    // The curve runs along the line but the matching puts every point at the start, so the
    // first piece is the whole curve while its segment is short: that is far.
    let c = spline(1, 2, 0.1, 0.0, 0);
    let rows = [ll(0.0, 0.0), ll(0.001, 0.0), ll(0.1, 0.0)];
    let q = PointSet::try_from_rows(&rows).unwrap();
    let good = two_way_distance(&c, &q, &[0.0, 0.01, 1.0], &TwoWayOptions::default()).unwrap();
    assert!(good.upper_rad < 1e-8, "{}", good.upper_rad);
    let bad = two_way_distance(&c, &q, &[0.0, 0.0, 1.0], &TwoWayOptions::default()).unwrap();
    assert!(bad.lower_rad > 9e-4, "{}", bad.lower_rad);
}

#[test]
fn bad_parameters_are_errors() {
    let c = spline(2, 5, 0.1, 0.1, 1);
    let q = PointSet::try_from_rows(&[ll(0.0, 0.0), ll(0.1, 0.0)]).unwrap();
    let o = TwoWayOptions::default();
    assert!(two_way_distance(&c, &q, &[0.5, 0.2], &o).is_err());
    assert!(two_way_distance(&c, &q, &[0.0], &o).is_err());
    assert!(two_way_distance(&c, &q, &[0.0, f64::NAN], &o).is_err());
}
