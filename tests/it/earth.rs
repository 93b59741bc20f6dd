//! The Earth layer as a batch reader uses it: one feature at a time, with the same result as
//! the HTTP service for the whole document, and errors that point into the document.

use serde_json::{json, Value};
use spherefit::earth::{process_feature, Document, Job, Operation, Problem, Sampling};
use spherefit::sphere::{FitOptions, KnotPlacement};

const BORDER: &str = include_str!("../../fixtures/us_mexico_border_natural_earth.geojson");

#[test]
fn feature_by_feature_equals_the_whole_document() {
    let fc: Value = serde_json::from_str(BORDER).unwrap();
    let job = Job::fit(FitOptions::default().with_control_points(20))
        .with_sampling(Sampling::Samples(200));
    job.validate().unwrap();
    // Streaming: each feature on its own, as a text-sequence reader would see it.
    let one_by_one: Vec<Value> = fc["features"]
        .as_array()
        .unwrap()
        .iter()
        .enumerate()
        .map(|(i, f)| {
            process_feature(f, &format!("/features/{i}"), &job)
                .unwrap()
                .feature
                .into_value()
        })
        .collect();
    // The whole document, as the service splits it.
    let doc = Document::parse(fc.clone(), false).unwrap();
    let outs: Vec<_> = doc.slots.iter().map(|s| s.process(&job).unwrap()).collect();
    for (a, b) in one_by_one.iter().zip(&outs) {
        assert_eq!(a, &b.feature.clone().into_value());
    }
    let stats = outs.iter().fold(
        Default::default(),
        |mut acc: spherefit::earth::FeatureStats, o| {
            acc.merge(&o.stats);
            acc
        },
    );
    assert_eq!(stats.curves, 3);
    assert_eq!(stats.input_points, 28 + 142 + 966);
    assert_eq!(stats.output_points, 600);
    // 20 control points x 2 coordinates + 16 interior knots + the degree, per curve (the end
    // knots are 0 and 1).
    assert_eq!(stats.stored_numbers, 3 * (40 + 16 + 1));
    assert!(stats.max_error_m > 0.0);
    let collection = doc
        .into_feature_collection(outs.into_iter().map(|o| o.feature).collect(), true)
        .into_value();
    assert_eq!(collection["features"].as_array().unwrap().len(), 3);
}

#[test]
fn errors_point_into_the_record() {
    let job = Job::fit(FitOptions::default());
    let bad = json!({"type": "Feature", "properties": {}, "geometry": {"type": "LineString",
        "coordinates": [[0, 0], [1, 1], [2, -91]]}});
    let e = process_feature(&bad, "", &job).unwrap_err();
    assert_eq!(e.pointer, "/geometry/coordinates/2/1");
    assert!(matches!(e.problem, Problem::InvalidCoordinate(_)));
    let e = process_feature(&bad, "/features/7", &job).unwrap_err();
    assert_eq!(e.pointer, "/features/7/geometry/coordinates/2/1");
    assert_eq!(e.problem.slug(), "invalid-coordinate");
}

#[test]
fn every_output_position_is_on_the_earth_and_rounded() {
    let job = Job::fit(FitOptions::default()).with_precision(5);
    let f = json!({"type": "Feature", "properties": null, "geometry": {"type": "LineString",
        "coordinates": (0..100).map(|i| [170.0 + i as f64 * 0.2, 80.0 + 9.0 * (i as f64 / 99.0)]).map(|[a, b]| [if a > 180.0 { a - 360.0 } else { a }, b]).collect::<Vec<_>>()}});
    let out = process_feature(&f, "", &job).unwrap().feature.into_value();
    let g = &out["geometry"];
    let lines: Vec<&Value> = match g["type"].as_str().unwrap() {
        "LineString" => vec![&g["coordinates"]],
        _ => g["coordinates"].as_array().unwrap().iter().collect(),
    };
    for l in lines {
        for p in l.as_array().unwrap() {
            let (lon, lat) = (p[0].as_f64().unwrap(), p[1].as_f64().unwrap());
            assert!((-180.0..=180.0).contains(&lon) && (-90.0..=90.0).contains(&lat));
            assert_eq!((lon * 1e5).round() / 1e5, lon, "rounded to 5 decimals");
        }
    }
}

/// One rule counts the numbers a B-spline stores, whichever path made it: a tolerance fit and a
/// plain fit with the same degree, control points and knots report the same count, and it
/// matches an independent count from the spline document in the output.
#[test]
fn fit_and_tolerance_fit_count_stored_numbers_alike() {
    let fc: Value = serde_json::from_str(BORDER).unwrap();
    let feature = &fc["features"][2];
    // (control points, degree, stored numbers) from the spline document in the output: 2
    // numbers per lon/lat control point, the interior knots unless uniform, the degree.
    let from_document = |out: &Value, uniform: bool| {
        let spline = &crate::helpers::resolved_spline(
            &out["properties"]["fit"]["spline"],
            &out["geometry"]["coordinates"],
        );
        let n = spline["control_points"].as_array().unwrap().len();
        let knots = spline["knots"].as_array().unwrap();
        let p = spline["degree"].as_u64().unwrap() as usize;
        assert_eq!(knots.len(), n + p + 1);
        assert_eq!(knots[0].as_f64(), Some(0.0));
        assert_eq!(knots[knots.len() - 1].as_f64(), Some(1.0));
        if uniform {
            for (i, k) in knots[p + 1..n].iter().enumerate() {
                assert_eq!(k.as_f64(), Some((i + 1) as f64 / (n - p) as f64));
            }
        }
        let interior = knots.len() - 2 * (p + 1);
        (n, p, 2 * n + if uniform { 0 } else { interior } + 1)
    };
    for tolerance_m in [100.0, 5.0] {
        let job = Job {
            operation: Operation::FitToTolerance {
                options: FitOptions::default(),
                tolerance_m,
            },
            ..Job::fit(FitOptions::default())
        };
        job.validate().unwrap();
        let t = process_feature(feature, "", &job).unwrap();
        let t_feature = t.feature.into_value();
        let fit_doc = &t_feature["properties"]["fit"];
        let uniform = fit_doc["knot_rule"] == "uniform";
        let (n, p, expected) = from_document(&t_feature, uniform);
        assert_eq!(t.stats.stored_numbers, expected, "{tolerance_m} m");
        assert_eq!(fit_doc["stored_numbers"].as_u64(), Some(expected as u64));

        // The same degree, control points and knot placement through a plain fit.
        let knots = if uniform {
            KnotPlacement::Uniform
        } else {
            KnotPlacement::Geodesic
        };
        let options = FitOptions::default()
            .with_control_points(n)
            .with_degree(p)
            .with_knots(knots);
        let f = process_feature(feature, "", &Job::fit(options)).unwrap();
        let (_, _, fit_expected) = from_document(&f.feature.clone().into_value(), uniform);
        assert_eq!(f.stats.stored_numbers, fit_expected, "{tolerance_m} m");
        assert_eq!(
            f.stats.stored_numbers, t.stats.stored_numbers,
            "{tolerance_m} m"
        );
    }
}
