//! Fitting to a tolerance: on every fixture line and at 1, 5, 25, 100 and 500 m, a fit
//! that reports `tolerance_met` really is within the tolerance, by its own metrics and by an
//! independent recomputation from the curve rebuilt out of its stored numbers (the two-way
//! distance is recomputed independently in `two_way.rs`).

use crate::helpers::{read_fixture_json, EARTH_RADIUS_M};
use spherefit::sphere::compress::simplify::{douglas_peucker, max_deviation};
use spherefit::sphere::compress::tolerance::{polyline_numbers, stored_numbers};
use spherefit::sphere::{
    fit_to_tolerance, KnotRule, PointSet, SphericalBSpline, ToleranceFit, ToleranceOptions,
};

const TOLERANCES_M: [f64; 5] = [1.0, 5.0, 25.0, 100.0, 500.0];

fn unit(lon_deg: f64, lat_deg: f64) -> [f64; 3] {
    let (lon, lat) = (lon_deg.to_radians(), lat_deg.to_radians());
    [lat.cos() * lon.cos(), lat.cos() * lon.sin(), lat.sin()]
}

struct Line {
    name: String,
    points: PointSet,
    /// Timestamps, where the fixture has usable ones (increasing, not all equal).
    times: Option<Vec<f64>>,
}

/// Every LineString of a fixture, repeated positions dropped (with their timestamps).
fn fixture_lines(file: &str) -> Vec<Line> {
    let doc = read_fixture_json(file);
    let mut out = Vec::new();
    for (i, f) in doc["features"].as_array().unwrap().iter().enumerate() {
        let coords = f["geometry"]["coordinates"].as_array().unwrap();
        let times = f["properties"]["timestamps_unix_s"].as_array();
        let mut rows: Vec<[f64; 3]> = Vec::new();
        let mut ts: Vec<f64> = Vec::new();
        for (j, c) in coords.iter().enumerate() {
            let v = unit(c[0].as_f64().unwrap(), c[1].as_f64().unwrap());
            if rows.last() != Some(&v) {
                rows.push(v);
                if let Some(t) = times {
                    ts.push(t[j].as_f64().unwrap());
                }
            }
        }
        let usable =
            ts.len() == rows.len() && ts.windows(2).all(|w| w[1] >= w[0]) && ts.last() > ts.first();
        out.push(Line {
            name: format!("{file} feature {i}"),
            points: PointSet::try_from_rows(&rows).unwrap(),
            times: usable.then_some(ts),
        });
    }
    out
}

/// A smooth meandering 5 km track, a point every 5 m.
fn smooth_track() -> Line {
    let rows: Vec<[f64; 3]> = (0..=1000)
        .map(|i| {
            let s = i as f64 * 5.0;
            let y = 300.0 * (s / 900.0).sin() + 800.0 * (s / 4000.0).sin();
            let lat = 46.0 + (y / EARTH_RADIUS_M).to_degrees();
            let lon = 14.0 + (s / (EARTH_RADIUS_M * 46f64.to_radians().cos())).to_degrees();
            unit(lon, lat)
        })
        .collect();
    Line {
        name: "smooth synthetic track".into(),
        points: PointSet::try_from_rows(&rows).unwrap(),
        times: None,
    }
}

/// The curve rebuilt from what a reader would store: the degree, each control point as lon/lat
/// in degrees, and the knots (read back, or derived by the uniform rule).
fn rebuild(fit: &ToleranceFit) -> SphericalBSpline {
    let s = &fit.spline;
    let (p, n) = (s.degree(), s.control_points().len());
    let knots = match fit.knot_rule {
        KnotRule::Stored => s.knots().to_vec(),
        KnotRule::Uniform => {
            let m = n - p;
            let mut k = vec![0.0; p + 1];
            k.extend((1..m).map(|i| i as f64 / m as f64));
            k.extend(std::iter::repeat_n(1.0, p + 1));
            assert_eq!(k, s.knots(), "the uniform rule gives the spline's knots");
            k
        }
    };
    let rows: Vec<[f64; 3]> = s
        .control_points()
        .iter()
        .map(|c| {
            let lat = c[2].clamp(-1.0, 1.0).asin().to_degrees();
            let lon = c[1].atan2(c[0]).to_degrees();
            unit(lon, lat)
        })
        .collect();
    SphericalBSpline::try_new(p, knots, PointSet::try_from_rows(&rows).unwrap()).unwrap()
}

/// Max error at the returned parameters, recomputed point by point with `evaluate` (not the
/// fitter's pass) and the half-chord formula for the angle.
fn independent_max_error(curve: &SphericalBSpline, points: &PointSet, params: &[f64]) -> f64 {
    points
        .iter()
        .zip(params)
        .map(|(q, &t)| {
            let c = curve.evaluate(t);
            let chord = q
                .iter()
                .zip(&c)
                .map(|(a, b)| (a - b) * (a - b))
                .sum::<f64>()
                .sqrt();
            2.0 * (0.5 * chord).min(1.0).asin()
        })
        .fold(0.0, f64::max)
}

fn check(line: &Line, tol_m: f64, params: Option<&[f64]>) -> ToleranceFit {
    let tol = tol_m / EARTH_RADIUS_M;
    let fit = fit_to_tolerance(&line.points, params, tol, &ToleranceOptions::default())
        .unwrap_or_else(|e| panic!("{} at {tol_m} m: {e}", line.name));
    let what = format!("{} at {tol_m} m (degree {})", line.name, fit.degree);
    assert_eq!(fit.parameters.len(), line.points.len(), "{what}");
    assert!(fit.parameters.windows(2).all(|w| w[1] >= w[0]), "{what}");
    // Met means the certified two-way distance (which bounds the vertex error) is within it;
    // tests/it/two_way.rs recomputes that distance independently.
    if fit.tolerance_met {
        assert!(
            fit.two_way_rad <= tol,
            "{what}: two-way {:e}",
            fit.two_way_rad
        );
        assert!(fit.curve_length_ratio <= 1.2, "{what}");
    }
    assert_eq!(
        fit.stored_numbers,
        stored_numbers(&fit.spline, fit.knot_rule)
    );
    assert_eq!(fit.input_numbers, polyline_numbers(line.points.len(), 3));
    for c in fit.spline.control_points().iter() {
        let norm = c.iter().map(|x| x * x).sum::<f64>().sqrt();
        assert!(
            (norm - 1.0).abs() < 1e-12,
            "{what}: control point norm {norm}"
        );
    }
    if let Some(t) = params {
        let (a, b) = (t[0], t[t.len() - 1]);
        for (got, given) in fit.parameters.iter().zip(t) {
            assert!(
                (got - (given - a) / (b - a)).abs() < 1e-12,
                "{what}: given parameters kept"
            );
        }
    }
    let independent = independent_max_error(&rebuild(&fit), &line.points, &fit.parameters);
    // The reported error is a measurement, not a bound: it agrees with the recomputation.
    assert!(
        (independent - fit.metrics.max_error_rad).abs() <= 1e-12 * tol.max(1e-3),
        "{what}: reported {:e} rad, recomputed {independent:e} rad",
        fit.metrics.max_error_rad
    );
    if fit.tolerance_met {
        assert!(fit.metrics.max_error_rad <= tol, "{what}");
        assert!(
            independent <= tol,
            "{what}: recomputed {} m",
            independent * EARTH_RADIUS_M
        );
    }
    fit
}

#[test]
fn every_fixture_line_meets_every_tolerance_it_claims() {
    let mut lines = fixture_lines("us_mexico_border_natural_earth.geojson");
    lines.extend(fixture_lines("gps_tracks_slovenia_gpxpy.geojson"));
    lines.push(smooth_track());
    let mut met = 0;
    for line in &lines {
        for tol_m in TOLERANCES_M {
            let fit = check(line, tol_m, None);
            // Without given parameters a polyline through the data is always available, so the
            // tolerance is always met.
            assert!(fit.tolerance_met, "{} at {tol_m} m", line.name);
            met += 1;
        }
    }
    assert_eq!(met, lines.len() * TOLERANCES_M.len());
}

#[test]
fn gps_timestamps_are_kept_as_parameters() {
    let lines = fixture_lines("gps_tracks_slovenia_gpxpy.geojson");
    let timed: Vec<&Line> = lines.iter().filter(|l| l.times.is_some()).collect();
    assert!(
        timed.len() >= 5,
        "the fixture has timestamps on most segments"
    );
    for line in timed {
        for tol_m in [5.0, 100.0] {
            check(line, tol_m, line.times.as_deref());
        }
    }
}

/// On a border of straight segments and corners the two-way bound leaves the spline little
/// room: it stores about what Douglas–Peucker does. (DP at exactly the tolerance bounds each
/// vertex's distance to its chord, not the ordered two-way distance, which it can miss where
/// the border doubles back within a chord; DP a hair under the tolerance is what the fitter
/// falls back to, one number more for the degree.)
#[test]
fn the_spline_stores_no_more_than_douglas_peucker_on_the_border() {
    let border = fixture_lines("us_mexico_border_natural_earth.geojson")
        .into_iter()
        .max_by_key(|l| l.points.len())
        .unwrap();
    for tol_m in [25.0, 100.0] {
        let tol = tol_m / EARTH_RADIUS_M;
        let kept = douglas_peucker(&border.points, 0.95 * tol);
        assert!(max_deviation(&border.points, &kept) <= tol);
        let fit = check(&border, tol_m, None);
        assert!(
            fit.stored_numbers <= polyline_numbers(kept.len(), 3) + 1,
            "{tol_m} m: spline {} numbers, Douglas–Peucker {}",
            fit.stored_numbers,
            polyline_numbers(kept.len(), 3)
        );
    }
}

#[test]
fn a_smooth_track_costs_at_most_half_of_douglas_peucker() {
    let line = smooth_track();
    for tol_m in [1.0, 5.0] {
        let kept = douglas_peucker(&line.points, tol_m / EARTH_RADIUS_M);
        let fit = check(&line, tol_m, None);
        assert!(
            fit.degree >= 2,
            "{tol_m} m: a smooth track wants a smooth curve"
        );
        assert!(
            2 * fit.stored_numbers <= polyline_numbers(kept.len(), 3),
            "{tol_m} m: spline {} numbers, Douglas–Peucker {}",
            fit.stored_numbers,
            polyline_numbers(kept.len(), 3)
        );
    }
}

#[test]
fn an_unreachable_tolerance_is_reported_not_hidden() {
    let line = smooth_track();
    // Two distinct points at one time: no curve passes through both at that parameter.
    let mut times: Vec<f64> = (0..line.points.len()).map(|i| i as f64).collect();
    times[500] = times[499];
    let fit = check(&line, 1.0, Some(&times));
    assert!(!fit.tolerance_met);
    assert!(fit.metrics.max_error_rad > 1.0 / EARTH_RADIUS_M);
    // A cap on control points does the same.
    let capped = fit_to_tolerance(
        &line.points,
        None,
        1.0 / EARTH_RADIUS_M,
        &ToleranceOptions::default().with_max_control_points(4),
    )
    .unwrap();
    assert!(!capped.tolerance_met);
    assert!(capped.spline.control_points().len() <= 4);
    assert!(capped.metrics.max_error_rad > 1.0 / EARTH_RADIUS_M);
}

#[test]
fn bad_tolerances_are_errors() {
    let line = smooth_track();
    for tol in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        assert!(fit_to_tolerance(&line.points, None, tol, &ToleranceOptions::default()).is_err());
    }
}
