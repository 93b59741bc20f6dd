//! Unit tests of fitting to a tolerance.

use super::*;
use crate::sphere::compress::simplify::{douglas_peucker, douglas_peucker_ordered};
use crate::sphere::curve::bspline::clamped_uniform_knots;
use crate::sphere::fit::knots::greville_control_points;

fn wave(n: usize, amplitude: f64, dim: usize) -> PointSet {
    let rows: Vec<Vec<f64>> = (0..n)
        .map(|i| {
            let a = i as f64 / (n - 1) as f64;
            let lat = amplitude * (9.0 * a).sin();
            let mut v = vec![lat.cos() * a.cos(), lat.cos() * a.sin(), lat.sin()];
            v.resize(dim, 0.0);
            if dim > 3 {
                v[3] = 0.1 * (4.0 * a).cos();
            }
            let norm = v.iter().map(|x| x * x).sum::<f64>().sqrt();
            v.iter().map(|x| x / norm).collect()
        })
        .collect();
    PointSet::try_from_rows(&rows).unwrap()
}

#[test]
fn stored_numbers_count_control_points_knots_and_the_degree() {
    let pts = wave(50, 0.01, 3);
    let knots = clamped_uniform_knots(6, 3);
    let ctrl = greville_control_points(
        &pts,
        &parameters(&pts, Parameterization::Chord).unwrap(),
        &knots,
        3,
    )
    .unwrap();
    let s = SphericalBSpline::try_new(3, knots, ctrl).unwrap();
    assert_eq!(stored_numbers(&s, KnotRule::Stored), 2 * 6 + 2 + 1);
    assert_eq!(stored_numbers(&s, KnotRule::Uniform), 2 * 6 + 1);
    assert_eq!(polyline_numbers(10, 4), 30);
}

#[test]
fn a_great_circle_within_the_tolerance_is_one_arc() {
    // Points on a great circle with wiggles of 1e-7 rad: at 1e-6 one arc suffices.
    let rows: Vec<[f64; 3]> = (0..200)
        .map(|i| {
            let a = i as f64 * 0.001;
            let lat = 1e-7 * (i as f64 * 0.7).sin();
            [lat.cos() * a.cos(), lat.cos() * a.sin(), lat.sin()]
        })
        .collect();
    let pts = PointSet::try_from_rows(&rows).unwrap();
    let fit = fit_to_tolerance(&pts, None, 1e-6, &ToleranceOptions::default()).unwrap();
    assert!(fit.tolerance_met);
    assert_eq!(fit.degree, 1);
    assert_eq!(fit.spline.control_points().len(), 2);
    assert_eq!(fit.stored_numbers, 5);
    assert_eq!(fit.knot_rule, KnotRule::Uniform);
}

#[test]
fn removal_beats_the_douglas_peucker_seed_and_the_errors_are_honest() {
    let pts = wave(600, 0.02, 3);
    let tol = 2e-5;
    let dp = douglas_peucker(&pts, tol).len();
    let opts = ToleranceOptions::default().with_degrees(&[1]);
    let fit = fit_to_tolerance(&pts, None, tol, &opts).unwrap();
    assert!(fit.tolerance_met);
    assert!(
        fit.spline.control_points().len() < dp,
        "{} vs {dp}",
        fit.spline.control_points().len()
    );
    let again = measure(&fit.spline, &pts, &fit.parameters);
    assert_eq!(again.max_error_rad, fit.metrics.max_error_rad);
    // Without removal the curve would be the Douglas–Peucker seed at the first vertex
    // share, which stores more than Douglas–Peucker at the tolerance: that polyline (or,
    // when DP at the tolerance misses the ordered two-way bound, the ordered DP at the
    // tolerance or DP a hair under it) is returned instead.
    let no_removal = fit_to_tolerance(&pts, None, tol, &opts.clone().with_reduce(false)).unwrap();
    let seed = douglas_peucker(&pts, internal_target(VERTEX_SHARES[0] * tol)).len();
    assert!(seed > dp);
    assert!(no_removal.tolerance_met);
    let dp_under = douglas_peucker(&pts, 0.95 * tol).len();
    let ordered = douglas_peucker_ordered(&pts, tol).len();
    assert!(no_removal.spline.control_points().len() <= dp_under.max(ordered));
    // The two-way distance is certified and met.
    let tw = two_way_distance(
        &fit.spline,
        &pts,
        &fit.parameters,
        &TwoWayOptions::default(),
    )
    .unwrap();
    assert!(tw.upper_rad <= tol && fit.two_way_rad <= tol);
    assert!(fit.curve_length_ratio < 1.01, "{}", fit.curve_length_ratio);
}

#[test]
fn works_on_s3_with_three_numbers_per_control_point() {
    let pts = wave(300, 0.05, 4);
    let fit = fit_to_tolerance(&pts, None, 1e-4, &ToleranceOptions::default()).unwrap();
    assert!(fit.tolerance_met, "{:e}", fit.metrics.max_error_rad);
    assert_eq!(fit.input_numbers, 3 * 300);
    let n = fit.spline.control_points().len();
    let knots = match fit.knot_rule {
        KnotRule::Stored => n - fit.degree - 1,
        KnotRule::Uniform => 0,
    };
    assert_eq!(fit.stored_numbers, 3 * n + knots + 1);
    assert!(fit.compression_ratio > 5.0, "{}", fit.compression_ratio);
}

#[test]
fn pinned_ends_are_the_end_points_bit_for_bit() {
    let pts = wave(400, 0.03, 3);
    let last = pts.len() - 1;
    for degrees in [&[1usize][..], &[2], &[3], &[1, 2, 3]] {
        let opts = ToleranceOptions::default()
            .with_degrees(degrees)
            .with_pin_ends(true);
        let fit = fit_to_tolerance(&pts, None, 2e-5, &opts).unwrap();
        assert!(fit.tolerance_met, "{degrees:?}");
        let c = fit.spline.control_points();
        assert_eq!(c.get(0), pts.get(0), "{degrees:?}");
        assert_eq!(c.get(c.len() - 1), pts.get(last), "{degrees:?}");
    }
    // A closed line pinned at its seam closes exactly.
    let rows: Vec<[f64; 3]> = (0..=200)
        .map(|i| {
            let a = std::f64::consts::TAU * (i % 200) as f64 / 200.0;
            let lat = 0.2 + 0.05 * a.sin() + 0.01 * (5.0 * a).cos();
            let lon = 0.08 * a.cos();
            [lat.cos() * lon.cos(), lat.cos() * lon.sin(), lat.sin()]
        })
        .collect();
    let ring = PointSet::try_from_rows(&rows).unwrap();
    let opts = ToleranceOptions::default().with_pin_ends(true);
    let fit = fit_to_tolerance(&ring, None, 1e-5, &opts).unwrap();
    assert!(fit.tolerance_met);
    let c = fit.spline.control_points();
    assert_eq!(c.get(0), c.get(c.len() - 1));
}

#[test]
fn given_parameters_use_stored_knots_and_stay_put() {
    let pts = wave(300, 0.02, 3);
    let t: Vec<f64> = (0..300).map(|i| (i as f64).powf(1.1)).collect();
    let fit = fit_to_tolerance(&pts, Some(&t), 1e-5, &ToleranceOptions::default()).unwrap();
    assert!(fit.tolerance_met);
    assert_eq!(fit.knot_rule, KnotRule::Stored);
    let expected = normalize_parameters(&t, 300).unwrap();
    assert_eq!(fit.parameters, expected);
}

#[test]
fn the_yardstick_counts_the_first_fallback_and_builds_it_only_when_asked() {
    let pts = wave(400, 0.01, 3);
    let params = parameters(&pts, Parameterization::Chord).unwrap();
    for (free, tol) in [(true, 1e-4), (true, 1e-3), (false, 1e-4)] {
        let line = Line {
            points: &pts,
            params: &params,
            free,
        };
        let eager = fallback::polyline_candidate(line, tol, 0).expect("a polyline");
        let mut lazy = fallback::Yardstick::new(line, tol);
        assert_eq!(lazy.numbers, stored_numbers(&eager.spline, eager.rule));
        let built = lazy.take_curve().expect("the same polyline");
        assert_eq!(built.spline, eager.spline);
        assert_eq!(built.params, eager.params);
        assert_eq!(built.rule, eager.rule);
    }
}

#[test]
fn the_greedy_polyline_stands_for_degree_one_when_it_beats_the_yardstick() {
    // A coastline-like line: steps of 1e-3 rad east, a slow wave and a jagged edge.
    let rows: Vec<[f64; 3]> = (0..600)
        .map(|i| {
            let jag = ((i * 7919) % 13) as f64 / 12.0 - 0.5;
            let lat = 3e-4 * (i as f64 * 0.05).sin() + 2e-4 * jag;
            let a = i as f64 * 1e-3;
            [lat.cos() * a.cos(), lat.cos() * a.sin(), lat.sin()]
        })
        .collect();
    let pts = PointSet::try_from_rows(&rows).unwrap();
    let options = ToleranceOptions::default().with_degrees(&[1]);
    let mut taken = 0;
    for tol in [5e-5, 1e-4, 1.2e-4, 1.5e-4, 2e-4, 4e-4, 8e-4] {
        let fit = fit_to_tolerance(&pts, None, tol, &options).unwrap();
        assert!(fit.tolerance_met && fit.two_way_rad <= tol);
        let greedy =
            stabbing::stabbing_polyline(&pts, internal_target(STABBING_SHARE * tol)).unwrap();
        let numbers = stored_numbers(&greedy.spline, greedy.rule);
        let yardstick = polyline_numbers(douglas_peucker(&pts, tol).len(), 3);
        let check = decide_options(tol, pts.len());
        let tw = two_way_distance(&greedy.spline, &pts, &greedy.params, &check).unwrap();
        eprintln!(
            "{tol} {numbers} {yardstick} {:?} {}",
            tw.exceeded,
            tw.upper_rad / tol
        );
        if numbers < yardstick && !tw.exceeded && tw.upper_rad <= tol {
            assert!(fit.spline.control_points() == greedy.spline.control_points());
            taken += 1;
        } else {
            assert!(fit.spline.control_points() != greedy.spline.control_points());
        }
    }
    assert!(
        taken >= 2,
        "the greedy polyline taken at {taken} tolerances"
    );
}
