//! Tracks in time (`parameterization=time`): the synchronized distance (SED) of every
//! timestamped fixture position recomputed here from the returned spline and time map, positions
//! at requested times against an independent de Boor evaluation, speed and heading from the
//! derivative against a synthetic track of known motion, times round-tripping through the dense
//! output (property and 4th coordinate), and bad time arrays as 422 with a pointer (HTTP) and a
//! non-zero exit with the pointer (CLI).

use crate::helpers::{angle, post_geo_oneshot as post, read_fixture_json, run_spherefit};
use crate::helpers::{slerp3 as slerp, unit3 as unit, EARTH_RADIUS_M};
use serde_json::{json, Value};

fn post_ok(uri: &str, body: &Value) -> Value {
    let (status, _, v) = post(uri, body);
    assert_eq!(status, 200, "{uri}: {v}");
    v
}

// ---------------------------------------------------------------------------------------------
// An independent evaluation: de Boor's algorithm with SLERP for every affine step (GLS-PIA
// §3.2), written out here from the definition.

fn lonlat(v: &[f64; 3]) -> (f64, f64) {
    (
        v[1].atan2(v[0]).to_degrees(),
        v[2].clamp(-1.0, 1.0).asin().to_degrees(),
    )
}

struct Spline {
    degree: usize,
    knots: Vec<f64>,
    control: Vec<[f64; 3]>,
}

impl Spline {
    /// The spline of `fit`, whose line is written at `positions` in the geometry.
    fn from_fit(fit: &Value, positions: &Value) -> Spline {
        let s = &crate::helpers::resolved_spline(&fit["spline"], positions);
        Spline {
            degree: s["degree"].as_u64().unwrap() as usize,
            knots: s["knots"]
                .as_array()
                .unwrap()
                .iter()
                .map(|k| k.as_f64().unwrap())
                .collect(),
            control: s["control_points"]
                .as_array()
                .unwrap()
                .iter()
                .map(|p| unit(p[0].as_f64().unwrap(), p[1].as_f64().unwrap()))
                .collect(),
        }
    }

    fn eval(&self, u: f64) -> [f64; 3] {
        let p = self.degree;
        let n = self.control.len();
        let u = u.clamp(self.knots[p], self.knots[n]);
        // The span k with knots[k] <= u < knots[k + 1] (the last non-empty one at the end).
        let mut k = p;
        while k + 1 < n && self.knots[k + 1] <= u {
            k += 1;
        }
        let mut d: Vec<[f64; 3]> = (0..=p).map(|j| self.control[k - p + j]).collect();
        for r in 1..=p {
            for j in (r..=p).rev() {
                let lo = self.knots[k - p + j];
                let hi = self.knots[k + 1 + j - r];
                let a = if hi > lo { (u - lo) / (hi - lo) } else { 0.0 };
                d[j] = slerp(&d[j - 1], &d[j], a);
            }
        }
        d[p]
    }
}

/// The stored time map: (start, end) unix seconds.
fn time_map(fit: &Value) -> (f64, f64) {
    let t = &fit["time"];
    (
        t["start_unix_s"].as_f64().unwrap(),
        t["end_unix_s"].as_f64().unwrap(),
    )
}

fn param(fit: &Value, t: f64) -> f64 {
    let (a, b) = time_map(fit);
    (t - a) / (b - a)
}

fn rfc3339(t: f64) -> String {
    jiff::Timestamp::from_second(t as i64).unwrap().to_string()
}

fn parse_time(v: &Value) -> f64 {
    match v {
        Value::String(s) => {
            let ts: jiff::Timestamp = s.parse().unwrap();
            ts.as_second() as f64 + ts.subsec_nanosecond() as f64 * 1e-9
        }
        v => v.as_f64().unwrap(),
    }
}

/// The fixture's tracks whose times are usable (six of eight: one has none, Mojstrovka's are
/// all one placeholder).
fn timed_tracks() -> Value {
    let mut fc = read_fixture_json("gps_tracks_slovenia_gpxpy.geojson");
    let features: Vec<Value> = fc["features"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|f| {
            let t = f["properties"]["timestamps_unix_s"].as_array();
            t.is_some_and(|t| t.windows(2).all(|w| w[1].as_f64() > w[0].as_f64()))
        })
        .cloned()
        .collect();
    assert_eq!(features.len(), 6);
    fc["features"] = Value::Array(features);
    fc
}

#[test]
fn the_sed_of_every_fixture_position_is_within_the_tolerance() {
    let input = timed_tracks();
    for tol in [5.0, 25.0] {
        let out = post_ok(
            &format!("/v1/fit?time_property=timestamps_unix_s&tolerance_m={tol}"),
            &input,
        );
        for (f_in, f_out) in input["features"]
            .as_array()
            .unwrap()
            .iter()
            .zip(out["features"].as_array().unwrap())
        {
            let fit = &f_out["properties"]["fit"];
            assert_eq!(fit["parameterization"], "time");
            assert_eq!(fit["tolerance_met"], true, "{tol}: {fit}");
            assert!(fit["two_way_distance_m"].as_f64().unwrap() <= tol);
            let spline = Spline::from_fit(fit, &f_out["geometry"]["coordinates"]);
            let times = f_in["properties"]["timestamps_unix_s"].as_array().unwrap();
            let coords = f_in["geometry"]["coordinates"].as_array().unwrap();
            let mut worst: f64 = 0.0;
            for (t, c) in times.iter().zip(coords) {
                let p = unit(c[0].as_f64().unwrap(), c[1].as_f64().unwrap());
                let q = spline.eval(param(fit, t.as_f64().unwrap()));
                let sed = angle(&p, &q) * EARTH_RADIUS_M;
                worst = worst.max(sed);
            }
            assert!(worst <= tol + 1e-3, "{tol}: SED {worst}");
            let reported = fit["max_error_m"].as_f64().unwrap();
            assert!((worst - reported).abs() < 2e-3, "{worst} vs {reported}");
            // The dense output carries one time per position, from the first to the last.
            let dense_t = f_out["properties"]["timestamps_unix_s"].as_array().unwrap();
            let dense = f_out["geometry"]["coordinates"].as_array().unwrap();
            assert_eq!(dense_t.len(), dense.len());
            assert_eq!(dense_t[0], times[0]);
            assert_eq!(dense_t.last(), times.last());
        }
    }
}

#[test]
fn without_time_the_same_tracks_are_not_within_the_sed() {
    // A chord-length fit can be within 25 m of the line and still far from where the walker
    // was at each time: the SED bound is a different promise.
    let input = timed_tracks();
    let out = post_ok("/v1/fit?tolerance_m=25", &input);
    let mut worst: f64 = 0.0;
    for (f_in, f_out) in input["features"]
        .as_array()
        .unwrap()
        .iter()
        .zip(out["features"].as_array().unwrap())
    {
        let fit = &f_out["properties"]["fit"];
        assert!(fit.get("time").is_none());
        let spline = Spline::from_fit(fit, &f_out["geometry"]["coordinates"]);
        let times = f_in["properties"]["timestamps_unix_s"].as_array().unwrap();
        let (t0, t1) = (
            times[0].as_f64().unwrap(),
            times.last().unwrap().as_f64().unwrap(),
        );
        for (t, c) in times
            .iter()
            .zip(f_in["geometry"]["coordinates"].as_array().unwrap())
        {
            let u = (t.as_f64().unwrap() - t0) / (t1 - t0);
            let p = unit(c[0].as_f64().unwrap(), c[1].as_f64().unwrap());
            worst = worst.max(angle(&p, &spline.eval(u)) * EARTH_RADIUS_M);
        }
    }
    assert!(worst > 100.0, "{worst}");
}

/// A synthetic track: constant speed along the great circle from A to B, one position every
/// 10 s for 20 minutes, times as RFC 3339 `coordTimes`.
fn synthetic_track() -> (Value, [f64; 3], [f64; 3], f64, f64) {
    let a = unit(13.0, 45.0);
    let b = unit(13.3, 45.2);
    let t0 = 1_714_816_800.0;
    let duration = 1200.0;
    let n = 121;
    let mut coords = Vec::new();
    let mut times = Vec::new();
    for i in 0..n {
        let f = i as f64 / (n - 1) as f64;
        let (lon, lat) = lonlat(&slerp(&a, &b, f));
        coords.push(json!([lon, lat]));
        times.push(json!(rfc3339(t0 + f * duration)));
    }
    let track = json!({"type": "Feature", "properties": {"coordTimes": times},
        "geometry": {"type": "LineString", "coordinates": coords}});
    (track, a, b, t0, duration)
}

/// Initial bearing (degrees from north, clockwise) from p towards q along the great circle.
fn bearing(p: &[f64; 3], q: &[f64; 3]) -> f64 {
    let (l1, f1) = lonlat(p);
    let (l2, f2) = lonlat(q);
    let (f1, f2, dl) = (f1.to_radians(), f2.to_radians(), (l2 - l1).to_radians());
    let y = dl.sin() * f2.cos();
    let x = f1.cos() * f2.sin() - f1.sin() * f2.cos() * dl.cos();
    y.atan2(x).to_degrees().rem_euclid(360.0)
}

#[test]
fn speed_and_heading_from_the_derivative_match_the_known_motion() {
    let (track, a, b, t0, duration) = synthetic_track();
    let speed = angle(&a, &b) * EARTH_RADIUS_M / duration;
    for query in [
        "/v1/fit?parameterization=time",
        "/v1/fit?parameterization=time&tolerance_m=1",
    ] {
        let fitted = post_ok(query, &track);
        let fit = &fitted["features"][0]["properties"]["fit"];
        assert_eq!(fit["time"]["format"], "rfc3339");
        assert_eq!(fit["time"]["source"], "coordTimes");
        let at: Vec<f64> = [37.0, 300.0, 615.5, 1000.0]
            .iter()
            .map(|s| t0 + s)
            .collect();
        // Mixed conventions in one query: RFC 3339 and unix seconds.
        let at_query = format!("{},{},{},{}", rfc3339(at[0]), at[1], at[2], rfc3339(at[3]));
        let ev = post_ok(&format!("/v1/evaluate?at={at_query}"), &fitted);
        let f = &ev["features"][0];
        assert_eq!(f["geometry"]["type"], "MultiPoint");
        let e = &f["properties"]["evaluation"];
        let spline = Spline::from_fit(fit, &fitted["features"][0]["geometry"]["coordinates"]);
        for (k, &t) in at.iter().enumerate() {
            // Position: the independent evaluation of the returned spline at u(t).
            let got = &f["geometry"]["coordinates"][k];
            let want = lonlat(&spline.eval(param(fit, t)));
            assert!(
                (got[0].as_f64().unwrap() - want.0).abs() < 1.5e-7
                    && (got[1].as_f64().unwrap() - want.1).abs() < 1.5e-7,
                "{query} at {t}: {got} vs {want:?}"
            );
            // And the known motion: where the track was at t.
            let truth = slerp(&a, &b, (t - t0) / duration);
            let p = unit(got[0].as_f64().unwrap(), got[1].as_f64().unwrap());
            assert!(angle(&p, &truth) * EARTH_RADIUS_M < 1.0, "{query} at {t}");
            let v = e["speed_mps"][k].as_f64().unwrap();
            assert!((v - speed).abs() < 0.005 * speed, "{query}: {v} vs {speed}");
            let h = e["heading_deg"][k].as_f64().unwrap();
            let want_h = bearing(&truth, &b);
            let dh = (h - want_h + 540.0).rem_euclid(360.0) - 180.0;
            assert!(dh.abs() < 0.2, "{query}: heading {h} vs {want_h}");
            assert_eq!(parse_time(&e["at"][k]), t);
        }
        // The times are written back in the track's convention.
        assert_eq!(f["properties"]["coordTimes"][0], json!(rfc3339(at[0])));
    }
}

#[test]
fn times_round_trip_through_the_dense_output() {
    let (track, _, _, t0, duration) = synthetic_track();
    let fitted = post_ok("/v1/fit?parameterization=time&spacing_s=30", &track);
    let f = &fitted["features"][0];
    let times = f["properties"]["coordTimes"].as_array().unwrap();
    let coords = f["geometry"]["coordinates"].as_array().unwrap();
    assert_eq!(times.len(), coords.len());
    assert_eq!(times.len(), (duration / 30.0) as usize + 1);
    assert_eq!(times[0], track["properties"]["coordTimes"][0]);
    assert_eq!(
        times.last(),
        track["properties"]["coordTimes"].as_array().unwrap().last()
    );
    let fit = &f["properties"]["fit"];
    let spline = Spline::from_fit(fit, &f["geometry"]["coordinates"]);
    for (k, (t, c)) in times.iter().zip(coords).enumerate() {
        let t = parse_time(t);
        assert_eq!(t, t0 + 30.0 * k as f64);
        let want = lonlat(&spline.eval(param(fit, t)));
        assert!((c[0].as_f64().unwrap() - want.0).abs() < 1.5e-7);
        assert!((c[1].as_f64().unwrap() - want.1).abs() < 1.5e-7);
    }
    // Evaluating the stored fit gives the same line and times.
    let ev = post_ok("/v1/evaluate?spacing_s=30", &fitted);
    assert_eq!(ev["features"][0]["geometry"], f["geometry"]);
    assert_eq!(
        ev["features"][0]["properties"]["coordTimes"],
        f["properties"]["coordTimes"]
    );

    // Unix seconds in `times` stay numbers; the 4th coordinate stays the 4th coordinate, with
    // the altitude interpolated linearly in time.
    let unix = json!({"type": "Feature", "properties": {"times": [0, 10, 30, 60, 100]},
        "geometry": {"type": "LineString", "coordinates":
            [[0, 0, 0], [0.001, 0, 10], [0.003, 0.0001, 30], [0.006, 0, 60], [0.01, 0, 100]]}});
    let out = post_ok("/v1/fit?parameterization=time&spacing_s=5", &unix);
    let t = out["features"][0]["properties"]["times"]
        .as_array()
        .unwrap();
    assert_eq!(t.len(), 21);
    assert_eq!(t[3], json!(15.0));
    let c = &out["features"][0]["geometry"]["coordinates"];
    // Altitude at 15 s: between 10 m (10 s) and 30 m (30 s).
    assert_eq!(c[3][2], json!(15.0));
    let mut m = unix.clone();
    m["properties"] = json!({});
    let coords: Vec<Value> = unix["geometry"]["coordinates"]
        .as_array()
        .unwrap()
        .iter()
        .zip(unix["properties"]["times"].as_array().unwrap())
        .map(|(p, t)| json!([p[0], p[1], p[2], t]))
        .collect();
    m["geometry"]["coordinates"] = Value::Array(coords);
    let out = post_ok("/v1/fit?parameterization=time&spacing_s=5", &m);
    let c = out["features"][0]["geometry"]["coordinates"]
        .as_array()
        .unwrap();
    assert_eq!(c.len(), 21);
    assert_eq!(c[3].as_array().unwrap().len(), 4);
    assert_eq!(
        (c[3][2].clone(), c[3][3].clone()),
        (json!(15.0), json!(15.0))
    );
    assert_eq!(
        out["features"][0]["properties"]["fit"]["time"]["source"],
        "M"
    );
}

#[test]
fn a_multilinestring_keeps_one_time_array_per_line() {
    let (track, _, _, t0, _) = synthetic_track();
    let coords = track["geometry"]["coordinates"].as_array().unwrap();
    let times = track["properties"]["coordTimes"].as_array().unwrap();
    let multi = json!({"type": "Feature", "properties": {"coordTimes": [times[..60], times[61..]]},
        "geometry": {"type": "MultiLineString", "coordinates": [coords[..60], coords[61..]]}});
    let out = post_ok("/v1/fit?parameterization=time&spacing_s=60", &multi);
    let f = &out["features"][0];
    assert_eq!(f["properties"]["fit"]["parameterization"], "time");
    let parts = f["properties"]["fit"]["parts"].as_array().unwrap();
    assert_eq!(parts.len(), 2);
    let t = f["properties"]["coordTimes"].as_array().unwrap();
    let g = f["geometry"]["coordinates"].as_array().unwrap();
    assert_eq!((t.len(), g.len()), (2, 2));
    for k in 0..2 {
        assert_eq!(
            t[k].as_array().unwrap().len(),
            g[k].as_array().unwrap().len()
        );
    }
    assert_eq!(t[1][0], times[61]);
    // A time in the second line is evaluated on the second part; one in the gap is refused.
    let second = parse_time(&times[100]);
    let ev = post_ok(&format!("/v1/evaluate?at={second}"), &out);
    let want = lonlat(
        &Spline::from_fit(&parts[1], &f["geometry"]["coordinates"][1])
            .eval(param(&parts[1], second)),
    );
    let got = &ev["features"][0]["geometry"]["coordinates"][0];
    assert!(
        (got[0].as_f64().unwrap() - want.0).abs() < 1.5e-7,
        "{got} {want:?}"
    );
    let gap = 0.5 * (parse_time(&times[59]) + parse_time(&times[61]));
    assert!(gap > t0);
    let (status, _, _) = post(&format!("/v1/evaluate?at={gap}"), &out);
    assert_eq!(status, 422);
}

#[test]
fn a_record_repeated_exactly_is_dropped_and_a_stop_is_kept() {
    // Position 2 repeats position 1 at the same time (a duplicate record); positions 3 and 4
    // are a stop: the same place at later times, which the curve in time must keep.
    let track = json!({"type": "Feature", "properties": {"times": [0, 10, 10, 20, 30, 40]},
        "geometry": {"type": "LineString", "coordinates":
            [[0, 0], [0.001, 0], [0.001, 0], [0.002, 0], [0.002, 0], [0.003, 0]]}});
    let out = post_ok("/v1/fit?parameterization=time&tolerance_m=0.5", &track);
    let fit = &out["features"][0]["properties"]["fit"];
    assert_eq!(fit["input_points"], 6);
    assert_eq!(fit["tolerance_met"], true, "{fit}");
    let spline = Spline::from_fit(fit, &out["features"][0]["geometry"]["coordinates"]);
    let stop = unit(0.002, 0.0);
    for t in [20.0, 25.0, 30.0] {
        let d = angle(&spline.eval(param(fit, t)), &stop) * EARTH_RADIUS_M;
        assert!(
            d < 0.5,
            "at {t} s the track stands still, the curve is {d} m away"
        );
    }
}

#[test]
fn bad_time_arrays_are_422_with_a_pointer() {
    let line = |props: Value| {
        json!({"type": "FeatureCollection", "features": [
            {"type": "Feature", "properties": {}, "geometry": {"type": "Point", "coordinates": [0, 0]}},
            {"type": "Feature", "properties": props, "geometry": {"type": "LineString",
             "coordinates": [[0, 0], [0.001, 0], [0.002, 0.0001], [0.003, 0]]}}]})
    };
    let fc = read_fixture_json("gps_tracks_slovenia_gpxpy.geojson");
    let mojstrovka = json!({"type": "FeatureCollection", "features": [fc["features"][7].clone()]});
    let cases: Vec<(&str, Value, &str, &str)> = vec![
        (
            "/v1/fit?time_property=timestamps_unix_s",
            mojstrovka,
            "/features/0/properties/timestamps_unix_s/1",
            "at a different position",
        ),
        (
            "/v1/fit?parameterization=time",
            line(json!({"times": [0, 10, 20, 15]})),
            "/features/1/properties/times/3",
            "earlier than time 2",
        ),
        (
            "/v1/fit?parameterization=time",
            line(
                json!({"coordTimes": ["2024-05-04T10:00:00Z", "2024-05-04T10:01:00Z", "2024-05-04T10:02:00Z"]}),
            ),
            "/features/1/properties/coordTimes",
            "3 times for 4 positions",
        ),
        (
            "/v1/fit?parameterization=time",
            line(
                json!({"coordTimes": ["2024-05-04T10:00:00Z", null, "2024-05-04T10:02:00Z", "2024-05-04T10:03:00Z"]}),
            ),
            "/features/1/properties/coordTimes/1",
            "got null",
        ),
        (
            "/v1/fit?parameterization=time",
            line(
                json!({"coordTimes": ["2024-05-04T10:00:00Z", "NaN", "2024-05-04T10:02:00Z", "2024-05-04T10:03:00Z"]}),
            ),
            "/features/1/properties/coordTimes/1",
            "RFC 3339",
        ),
        (
            "/v1/fit?parameterization=time",
            line(json!({"times": [0, "2024-05-04T10:01:00Z", 2, 3]})),
            "/features/1/properties/times/1",
            "write all times of a line one way",
        ),
        (
            "/v1/fit?parameterization=time",
            line(json!({})),
            "/features/1/geometry/coordinates",
            "no times",
        ),
        (
            "/v1/fit?time_property=when",
            line(json!({"times": [0, 1, 2, 3]})),
            "/features/1/properties",
            "\"when\"",
        ),
        (
            "/v1/fit?parameterization=time",
            json!({"type": "LineString", "coordinates": [[0, 0, 0, 0], [0.001, 0, 0, 10], [0.002, 0, 0, 5]]}),
            "/coordinates/2/3",
            "earlier",
        ),
        (
            "/v1/fit?parameterization=time",
            json!({"type": "Feature", "properties": {"times": [[0, 1]]}, "geometry": {"type": "MultiLineString",
                "coordinates": [[[0, 0], [0.001, 0]], [[0.002, 0], [0.003, 0]]]}}),
            "/properties/times",
            "line 1 has none",
        ),
        (
            "/v1/fit?parameterization=time",
            json!({"type": "Feature", "properties": {"times": [0, 1, 2, 3]}, "geometry": {"type": "Polygon",
                "coordinates": [[[0, 0], [0.001, 0], [0.001, 0.001], [0, 0]]]}}),
            "/geometry/type",
            "rings have no time order",
        ),
    ];
    for (uri, body, pointer, says) in cases {
        let (status, ct, v) = post(uri, &body);
        assert_eq!(status, 422, "{uri} {pointer}: {v}");
        assert!(ct.starts_with("application/problem+json"), "{ct}");
        assert_eq!(v["pointer"], pointer, "{v}");
        assert_eq!(v["type"], "urn:spherefit:problem:invalid-time", "{v}");
        assert!(v["detail"].as_str().unwrap().contains(says), "{says}: {v}");
    }
    // A fit in time asked at a time outside its track, or a fit not in time asked at a time.
    let (track, _, _, t0, _) = synthetic_track();
    let fitted = post_ok("/v1/fit?parameterization=time", &track);
    let (status, _, v) = post(&format!("/v1/evaluate?at={}", t0 - 1.0), &fitted);
    assert_eq!(
        (status, v["pointer"].as_str()),
        (422, Some("/features/0/properties/fit"))
    );
    assert!(
        v["detail"].as_str().unwrap().contains("not extrapolated"),
        "{v}"
    );
    let plain = post_ok("/v1/fit", &track);
    let (status, _, v) = post(&format!("/v1/evaluate?at={t0}"), &plain);
    assert_eq!(
        (status, v["pointer"].as_str()),
        (422, Some("/features/0/properties/fit"))
    );
    // Unparsable and conflicting options.
    let (status, _, v) = post("/v1/evaluate?at=noon", &fitted);
    assert_eq!((status, v["parameter"].as_str()), (422, Some("at")));
    let (status, _, v) = post("/v1/fit?parameterization=chord&time_property=t", &track);
    assert_eq!(
        (status, v["parameter"].as_str()),
        (422, Some("time_property"))
    );
    let (status, _, v) = post("/v1/evaluate?at=1&samples=10", &fitted);
    assert_eq!((status, v["parameter"].as_str()), (422, Some("at")));
    // Output over the limit is refused before it is made, naming spacing_s.
    let (status, _, v) = post("/v1/fit?parameterization=time&spacing_s=0.001", &track);
    assert_eq!(
        (status, v["parameter"].as_str()),
        (422, Some("spacing_s")),
        "{v}"
    );
    // A bare spline document has no times.
    let bare = json!({"crs": "lonlat", "degree": 1, "knots": [0, 0, 1, 1], "control_points": [[0, 0], [1, 0]]});
    let (status, _, v) = post("/v1/evaluate?at=1", &bare);
    assert_eq!(
        (status, v["type"].as_str()),
        (422, Some("urn:spherefit:problem:invalid-spline")),
        "{v}"
    );
    let (status, _, v) = post("/v1/evaluate?spacing_s=10", &plain);
    assert_eq!(
        (status, v["parameter"].as_str()),
        (422, Some("spacing_s")),
        "{v}"
    );
}

#[test]
fn the_cli_fits_evaluates_and_refuses_like_the_service() {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("time_cli");
    std::fs::create_dir_all(&dir).unwrap();
    let (track, _, _, t0, _) = synthetic_track();
    let input = dir.join("track.geojson");
    std::fs::write(&input, serde_json::to_vec(&track).unwrap()).unwrap();
    let o = run_spherefit(
        &[
            "fit",
            "--parameterization",
            "time",
            "-q",
            input.to_str().unwrap(),
        ],
        None,
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let fitted: Value = serde_json::from_slice(&o.stdout).unwrap();
    let service = post_ok("/v1/fit?parameterization=time", &track);
    assert_eq!(fitted, service);
    let at = format!("{},{}", t0 + 100.0, rfc3339(t0 + 200.0));
    let o = run_spherefit(
        &["evaluate", "--at", &at, "-q"],
        Some(&serde_json::to_vec(&fitted).unwrap()),
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let ev: Value = serde_json::from_slice(&o.stdout).unwrap();
    let from_service = post_ok(&format!("/v1/evaluate?at={at}"), &fitted);
    assert_eq!(ev, from_service);
    assert_eq!(
        ev["features"][0]["properties"]["evaluation"]["speed_mps"]
            .as_array()
            .unwrap()
            .len(),
        2
    );

    // Bad times: the record fails (exit 1) with the pointer and the reason.
    let mut bad = track.clone();
    bad["properties"]["coordTimes"][5] = json!("2024-05-04T09:00:00Z");
    let o = run_spherefit(
        &["fit", "--parameterization", "time", "-q"],
        Some(&serde_json::to_vec(&bad).unwrap()),
    );
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("/properties/coordTimes/5") && err.contains("strictly increase"),
        "{err}"
    );
    // A bad --at, or --time-property with another parameterization: usage errors (exit 2).
    let o = run_spherefit(&["evaluate", "--at", "noon"], Some(b"{}"));
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--at"));
    let o = run_spherefit(
        &["fit", "--parameterization", "chord", "--time-property", "t"],
        Some(b"{}"),
    );
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--time-property"));
}
