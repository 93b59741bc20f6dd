use super::*;
use crate::earth::curve::stored::CONTROL_POINTS_OF_GEOMETRY;
use crate::sphere::FitOptions;

fn wave(n: usize, lon0: f64) -> Value {
    json!((0..n)
        .map(|i| [lon0 + i as f64 * 0.05, 2.0 * (i as f64 * 0.2).sin()])
        .collect::<Vec<_>>())
}

#[test]
fn collection_order_ids_and_members_survive() {
    let doc = json!({
        "type": "FeatureCollection", "name": "test", "bbox": [0, 0, 1, 1],
        "features": [
            {"type": "Feature", "id": "a", "properties": {"k": 1}, "geometry": {"type": "Point", "coordinates": [1, 2]}},
            {"type": "Feature", "id": 2, "properties": null, "foo": [1], "bbox": [0, 0, 0, 0],
             "geometry": {"type": "LineString", "coordinates": wave(40, 0.0)}},
            {"type": "Feature", "properties": {}, "geometry": null}
        ]
    });
    let d = Document::parse(doc.clone(), false).unwrap();
    let job = Job::fit(FitOptions::default());
    let outs: Vec<ProcessedFeature> = d.slots.iter().map(|s| s.process(&job).unwrap()).collect();
    assert_eq!(outs[0].feature.clone().into_value(), doc["features"][0]);
    assert_eq!(outs[2].feature.clone().into_value(), doc["features"][2]);
    let f = outs[1].feature.clone().into_value();
    assert_eq!(f["id"], 2);
    assert_eq!(f["foo"], json!([1]));
    assert!(f.get("bbox").is_none());
    assert!(f["properties"]["fit"]["max_error_m"].is_number());
    assert_eq!(outs[1].stats.curves, 1);
    let fc = d
        .into_feature_collection(outs.into_iter().map(|o| o.feature).collect(), true)
        .into_value();
    assert_eq!(fc["name"], "test");
    assert!(fc.get("bbox").is_none());
    assert_eq!(fc["features"].as_array().unwrap().len(), 3);
}

#[test]
fn errors_point_into_the_collection() {
    let doc = json!({"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {}, "geometry": {"type": "LineString", "coordinates": wave(10, 0.0)}},
        {"type": "Feature", "properties": {}, "geometry": {"type": "MultiLineString", "coordinates": [wave(10, 0.0), [[0, 0], [1, 95]]]}}
    ]});
    let d = Document::parse(doc, false).unwrap();
    let job = Job::fit(FitOptions::default());
    assert!(d.slots[0].process(&job).is_ok());
    let e = d.slots[1].process(&job).unwrap_err();
    assert_eq!(e.pointer, "/features/1/geometry/coordinates/1/1/1");
}

#[test]
fn fit_then_evaluate_reproduces_the_geometry() {
    let doc = json!({"type": "MultiLineString", "coordinates": [wave(30, 0.0), wave(30, 20.0)]});
    let job = Job::fit(FitOptions::default()).with_sampling(super::super::Sampling::Samples(50));
    let fitted = Document::parse(doc, false).unwrap().slots[0]
        .process(&job)
        .unwrap()
        .feature
        .into_value();
    assert_eq!(
        fitted["properties"]["fit"]["parts"]
            .as_array()
            .unwrap()
            .len(),
        2
    );
    let ev_job = Job::evaluate().with_sampling(super::super::Sampling::Samples(50));
    let evaluated = process_feature(&fitted, "", &ev_job)
        .unwrap()
        .feature
        .into_value();
    assert_eq!(evaluated["geometry"], fitted["geometry"]);
}

#[test]
fn bare_spline_documents_need_a_crs() {
    let doc = json!({"degree": 1, "knots": [0, 0, 1, 1], "control_points": [[0, 0], [10, 0]]});
    let e = Document::parse(doc.clone(), true).unwrap_err();
    assert_eq!(e.pointer, "/crs");
    let mut with_crs = doc;
    with_crs["crs"] = json!("lonlat");
    let d = Document::parse(with_crs, true).unwrap();
    let out = d.slots[0]
        .process(&Job::evaluate().with_sampling(super::super::Sampling::Samples(11)))
        .unwrap();
    let out = out.feature.into_value();
    let coords = out["geometry"]["coordinates"].as_array().unwrap();
    assert_eq!(coords.len(), 11);
    assert_eq!(coords[5], json!([5.0, 0.0]));
}

/// A degree-1 tolerance fit's spline refers to its geometry unless the job says it is read
/// back without it (Python's `fit` column); either way its positions are the geometry's.
#[test]
fn a_degree_one_spline_refers_to_its_geometry_unless_told_not_to() {
    let mut raw = crate::earth::RawOptions::default();
    raw.set("tolerance_m", "1000").unwrap();
    let job = crate::earth::into_job(
        raw,
        crate::earth::OperationKind::Fit,
        &crate::earth::Limits::default(),
    )
    .unwrap();
    let line = json!({"type": "Feature", "properties": {},
        "geometry": {"type": "LineString", "coordinates": wave(40, 0.0)}});
    let run = |job: &Job| {
        let d = Document::parse(line.clone(), false).unwrap();
        d.slots[0].process(job).unwrap().feature.into_value()
    };
    let referring = run(&job);
    let spline = &referring["properties"]["fit"]["spline"];
    assert_eq!(spline["degree"], 1, "{spline}");
    assert_eq!(spline["control_points"], CONTROL_POINTS_OF_GEOMETRY);
    assert!(spline.get("knots").is_none());
    let whole = run(&job.clone().splines_referring_to_geometry(false));
    let spline = &whole["properties"]["fit"]["spline"];
    let rows: Vec<Value> = whole["geometry"]["coordinates"].as_array().unwrap().clone();
    assert_eq!(spline["control_points"], Value::Array(rows));
    assert_eq!(whole["geometry"], referring["geometry"]);
}
