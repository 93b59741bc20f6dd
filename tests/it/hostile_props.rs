//! Property tests on the parsers and option readers (in place of cargo-fuzz, whose
//! ASAN build takes 13 minutes here): GeoJSON documents, S^n points and spline documents, and
//! the query parameters of the fit and evaluate routes, generated at random (structured values
//! near the valid ones, plus noise). Nothing may panic, every error names where it is, and
//! every success is finite. 512 cases each, a few seconds in total in release.

use proptest::prelude::*;
use serde_json::{json, Value};
use spherefit::earth::{Document, Job, Limits, Sampling};
use spherefit::service::{router, AppState, ServiceConfig};
use tower::ServiceExt;

/// Numbers that hurt: extremes, subnormals, NaN-like (JSON has none), zero, ordinary values.
fn number() -> impl Strategy<Value = Value> {
    prop_oneof![
        (-200.0f64..200.0).prop_map(|x| json!(x)),
        prop::sample::select(vec![
            0.0, -0.0, 1e308, -1e308, 5e-324, 180.0, -180.0, 90.0, -90.0, 1e-300
        ])
        .prop_map(|x| json!(x)),
        any::<i64>().prop_map(|x| json!(x)),
    ]
}

/// JSON values near GeoJSON: positions, arrays of them, objects with the usual keys.
fn value() -> impl Strategy<Value = Value> {
    let leaf = prop_oneof![
        number(),
        Just(Value::Null),
        any::<bool>().prop_map(Value::Bool),
        prop::sample::select(vec![
            "LineString",
            "Polygon",
            "MultiPolygon",
            "Feature",
            "lonlat",
            "bspline",
            "beta",
            "x"
        ])
        .prop_map(|s| json!(s)),
    ];
    leaf.prop_recursive(5, 200, 8, |inner| {
        prop_oneof![
            prop::collection::vec(inner.clone(), 0..8).prop_map(Value::Array),
            prop::collection::vec(
                (
                    prop::sample::select(vec![
                        "type",
                        "coordinates",
                        "geometry",
                        "properties",
                        "features",
                        "fit",
                        "parts",
                        "path",
                        "degree",
                        "knots",
                        "control_points",
                        "crs",
                        "points",
                        "parameters",
                        "segments",
                        "beta1",
                        "beta2",
                        "id",
                        "bbox",
                    ]),
                    inner
                ),
                0..6
            )
            .prop_map(|kv| Value::Object(
                kv.into_iter().map(|(k, v)| (k.to_string(), v)).collect()
            )),
        ]
    })
}

fn lines() -> impl Strategy<Value = Value> {
    prop::collection::vec(prop::collection::vec((number(), number()), 0..12), 1..4).prop_map(|ls| {
        let coords: Vec<Value> = ls
            .into_iter()
            .map(|l| Value::Array(l.into_iter().map(|(a, b)| json!([a, b])).collect()))
            .collect();
        json!({"type": "FeatureCollection", "features": [
            {"type": "Feature", "properties": {}, "geometry": {"type": "MultiLineString", "coordinates": coords.clone()}},
            {"type": "Feature", "properties": {}, "geometry": {"type": "Polygon", "coordinates": coords}}
        ]})
    })
}

fn small_job(job: Job) -> Job {
    job.with_limits(Limits {
        max_control_points: 50,
        max_samples: 200,
        max_iterations: 20,
    })
    .with_sampling(Sampling::Samples(20))
}

fn check_finite(v: &Value) {
    match v {
        Value::Null => {}
        Value::Number(n) => assert!(n.as_f64().is_some_and(f64::is_finite)),
        Value::Array(a) => a.iter().for_each(check_finite),
        Value::Object(m) => m.values().for_each(check_finite),
        _ => {}
    }
}

fn run_document(doc: Value) {
    for (job, allow_spline) in [
        (small_job(Job::fit(Default::default())), false),
        (small_job(Job::evaluate()), true),
        (small_job(Job::interpolate(Default::default())), false),
    ] {
        if let Ok(d) = Document::parse(doc.clone(), allow_spline) {
            for slot in &d.slots {
                match slot.process(&job) {
                    Ok(p) => check_finite(&p.feature.into_value()["geometry"]),
                    Err(e) => assert!(e.pointer.is_empty() || e.pointer.starts_with('/'), "{e:?}"),
                }
            }
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 512, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn geojson_documents_never_panic(doc in value()) {
        run_document(doc);
    }

    #[test]
    fn near_valid_lines_never_panic_and_stay_finite(doc in lines()) {
        run_document(doc);
    }

    #[test]
    fn sphere_documents_never_panic(doc in value()) {
        if let Ok(input) = spherefit::document::PointsInput::from_json(&doc) {
            let _ = spherefit::sphere::fit::fit(&input.points, input.parameters.as_deref(), &spherefit::sphere::FitOptions { iterations: 5, ..Default::default() });
        }
        if let Ok(c) = spherefit::document::curve_from_json(&doc) {
            use spherefit::sphere::SphericalCurve;
            let ts = spherefit::sphere::curve::even_parameters(c.domain(), 5);
            let _ = c.evaluate_many(&ts);
        }
    }

    #[test]
    fn fit_and_evaluate_options_never_panic(
        pairs in prop::collection::vec((
            prop::sample::select(vec!["degree", "control_points", "samples", "spacing_m", "precision", "iterations", "tolerance_m", "knots", "parameterization", "solver", "beta1", "beta2", "at", "x"]),
            prop::sample::select(vec!["0", "1", "3", "-1", "1e308", "NaN", "inf", "0.5", "uniform", "chord", "", "99999999999999999999", "2", "1,2"]),
        ), 0..5),
        path in prop::sample::select(vec!["/v1/fit", "/v1/interpolate", "/v1/evaluate", "/v1/sphere/fit", "/v1/sphere/evaluate"]),
    ) {
        let query: Vec<String> = pairs.iter().map(|(k, v)| format!("{k}={v}")).collect();
        let uri = format!("{path}?{}", query.join("&"));
        let body = if path.starts_with("/v1/sphere/evaluate") {
            json!({"degree": 1, "knots": [0, 0, 1, 1], "control_points": [[1, 0, 0], [0, 1, 0]]})
        } else if path.starts_with("/v1/sphere") {
            json!({"points": [[1, 0, 0], [0.8, 0.6, 0], [0, 1, 0], [0, 0.6, 0.8]]})
        } else if path == "/v1/evaluate" {
            json!({"crs": "lonlat", "degree": 1, "knots": [0, 0, 1, 1], "control_points": [[0, 0], [10, 0]]})
        } else {
            json!({"type": "LineString", "coordinates": [[0, 0], [1, 1], [2, 0], [3, 1]]})
        };
        let status = RUNTIME.with(|rt| rt.block_on(async {
            let app = router(AppState::new(ServiceConfig::default()));
            let req = axum::http::Request::post(uri)
                .header("content-type", "application/json")
                .body(axum::body::Body::from(body.to_string()))
                .unwrap();
            app.oneshot(req).await.unwrap().status().as_u16()
        }));
        prop_assert!(status == 200 || (400..500).contains(&status), "{status} for {pairs:?} on {path}");
    }
}

thread_local! {
    static RUNTIME: tokio::runtime::Runtime = tokio::runtime::Builder::new_current_thread().enable_all().build().unwrap();
}
