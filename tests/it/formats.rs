//! Issue 56: Shapefile, GeoPackage, FlatGeobuf, GPX and TopoJSON in and out.
//!
//! * Each format read (`spherefit::formats`) gives the features of the GeoJSON it was made from
//!   with `ogr2ogr` (`fixtures/formats/`, see `fixtures/README.md`): same order, properties
//!   (with their types), ids, coordinates; the world-atlas TopoJSON gives exactly what
//!   `topojson-client` decoded (`coverage_world_110m.geojson`).
//! * Projected copies (EPSG:3857 GeoPackage, EPSG:32633 Shapefile) fit to within 1 cm of the
//!   lon/lat original, and the run says which CRS they came in; an unknown CRS and truncated
//!   files are refused naming the file, record and byte.
//! * Each format written is read back by GDAL (`ogrinfo` for the driver and count, `ogr2ogr`
//!   for the values) with every feature, property and position of the GeoJSON output. A
//!   missing GDAL skips that half with a notice, unless `SPHEREFIT_TEST_TOOLS=required` (set
//!   by `.ci/run`), where it fails.

use crate::helpers::{fixture_path, lonlat_to_unit, run_spherefit, EARTH_RADIUS_M};
use serde_json::Value;
use spherefit::formats::{self, Kind, ReadOptions};
use std::path::{Path, PathBuf};
use std::process::Command;

fn scratch(name: &str) -> PathBuf {
    let d = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("formats-{name}"));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn tools_required() -> bool {
    std::env::var("SPHEREFIT_TEST_TOOLS").as_deref() == Ok("required")
}

/// Every feature of every layer of a file, read by `spherefit::formats`.
fn read_all(path: &str, layer: Option<&str>) -> Vec<Value> {
    let head = std::fs::read(path).unwrap();
    let kind = Kind::detect(Some(Path::new(path)), &head[..head.len().min(1024)]).unwrap();
    let options = ReadOptions {
        layer: layer.map(str::to_string),
    };
    let source = formats::open(Path::new(path), path, kind, &options).unwrap();
    source
        .layers
        .into_iter()
        .flat_map(|l| l.features)
        .map(Result::unwrap)
        .collect()
}

fn json_file(p: &Path) -> Value {
    serde_json::from_slice(&std::fs::read(p).unwrap()).unwrap()
}

/// The rings (or lines) of a geometry, each as a list of positions.
fn lines(g: &Value) -> Vec<Vec<Vec<f64>>> {
    let pos = |v: &Value| -> Vec<Vec<f64>> {
        v.as_array()
            .unwrap()
            .iter()
            .map(|p| {
                p.as_array()
                    .unwrap()
                    .iter()
                    .map(|x| x.as_f64().unwrap())
                    .collect()
            })
            .collect()
    };
    let c = &g["coordinates"];
    match g["type"].as_str().unwrap() {
        "LineString" => vec![pos(c)],
        "Polygon" | "MultiLineString" => c.as_array().unwrap().iter().map(pos).collect(),
        "MultiPolygon" => c
            .as_array()
            .unwrap()
            .iter()
            .flat_map(|p| p.as_array().unwrap().iter().map(pos))
            .collect(),
        t => panic!("unexpected {t}"),
    }
}

/// Same rings, each equal or reversed (a Shapefile stores outer rings clockwise).
fn same_rings(a: &Value, b: &Value) -> bool {
    let (la, lb) = (lines(a), lines(b));
    la.len() == lb.len()
        && la.iter().zip(&lb).all(|(x, y)| {
            let mut r = y.clone();
            r.reverse();
            x == y || *x == r
        })
}

#[test]
fn each_format_reads_the_features_it_was_made_from() {
    let original = json_file(Path::new(&fixture_path("coverage_us_states.geojson")));
    let want = original["features"].as_array().unwrap();
    for file in [
        "us_states.shp",
        "us_states.zip",
        "us_states.gpkg",
        "us_states.fgb",
    ] {
        let got = read_all(&fixture_path(&format!("formats/{file}")), None);
        assert_eq!(got.len(), want.len(), "{file}");
        for (i, (g, w)) in got.iter().zip(want).enumerate() {
            // ogr2ogr turned the string ids into an `id` column.
            assert_eq!(g["properties"]["id"], w["id"], "{file} feature {i}");
            assert_eq!(
                g["properties"]["name"], w["properties"]["name"],
                "{file} feature {i}"
            );
            assert!(
                same_rings(&g["geometry"], &w["geometry"]),
                "{file} feature {i}"
            );
        }
        if file.ends_with(".gpkg") {
            // The GeoPackage's feature ids are the ids.
            let ids: Vec<i64> = got.iter().map(|f| f["id"].as_i64().unwrap()).collect();
            assert_eq!(ids, (1..=11).collect::<Vec<_>>());
        }
    }
    // Attribute types: integers, reals, booleans (as GDAL stores them: an integer in a
    // Shapefile), text.
    let tracks = read_all(&fixture_path("formats/tracks_32633.shp"), None);
    let original = json_file(Path::new(&fixture_path(
        "gps_tracks_slovenia_gpxpy.geojson",
    )));
    for (g, w) in tracks.iter().zip(original["features"].as_array().unwrap()) {
        let (p, q) = (&g["properties"], &w["properties"]);
        assert_eq!(p["name"], q["name"]);
        assert_eq!(p["n_points"], q["n_points"]);
        assert!(p["n_points"].is_i64());
        assert_eq!(p["length_km"].as_f64(), q["length_km"].as_f64());
        assert_eq!(p["closed"], Value::from(i64::from(q["closed"] == true)));
    }
}

#[test]
fn topojson_decodes_as_topojson_client_does() {
    let got = read_all(
        &fixture_path("formats/world_atlas_countries_110m.topojson"),
        Some("countries"),
    );
    let want = json_file(Path::new(&fixture_path("coverage_world_110m.geojson")));
    let want = want["features"].as_array().unwrap();
    assert_eq!(got.len(), want.len());
    for (g, w) in got.iter().zip(want) {
        assert_eq!(g["id"], w["id"]);
        assert_eq!(g["properties"]["name"], w["properties"]["name"]);
        let (a, b) = (lines(&g["geometry"]), lines(&w["geometry"]));
        assert_eq!(a.len(), b.len(), "{}", w["properties"]["name"]);
        for (x, y) in a.iter().zip(&b) {
            assert_eq!(x.len(), y.len());
            for (p, q) in x.iter().zip(y) {
                assert!(
                    (p[0] - q[0]).abs() < 1e-9 && (p[1] - q[1]).abs() < 1e-9,
                    "{p:?} {q:?}"
                );
            }
        }
    }
    // Both objects without --layer; a missing layer is refused naming what there is.
    let both = read_all(
        &fixture_path("formats/world_atlas_countries_110m.topojson"),
        None,
    );
    assert_eq!(both.len(), want.len() + 1);
    let o = run_spherefit(
        &[
            "fit",
            "--layer",
            "rivers",
            &fixture_path("formats/world_atlas_countries_110m.topojson"),
        ],
        None,
    );
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("\"rivers\"") && err.contains("countries"),
        "{err}"
    );
}

#[test]
fn gpx_tracks_are_fitted_in_time() {
    let gpx = fixture_path("formats/cerknicko-jezero.gpx");
    let tracks = read_all(&gpx, Some("tracks"));
    // Tracks whose segments are all empty have no geometry (and pass through).
    let tracks: Vec<Value> = tracks
        .into_iter()
        .filter(|t| !t["geometry"].is_null())
        .collect();
    assert!(!tracks.is_empty());
    for t in &tracks {
        let n = lines(&t["geometry"]).iter().map(Vec::len).sum::<usize>();
        let times = &t["properties"]["coordTimes"];
        let count = match times[0].as_array() {
            Some(_) => times
                .as_array()
                .unwrap()
                .iter()
                .map(|l| l.as_array().unwrap().len())
                .sum(),
            None => times.as_array().unwrap().len(),
        };
        assert_eq!(count, n, "one time per point");
    }
    let waypoints = read_all(&gpx, Some("waypoints"));
    assert_eq!(waypoints.len(), 7);
    assert_eq!(waypoints[0]["properties"]["time"], "2010-08-05T14:23:59Z");
    let dir = scratch("gpx");
    let out = dir.join("out.geojson");
    let o = run_spherefit(
        &[
            "fit",
            "-q",
            "--layer",
            "tracks",
            "--tolerance-m",
            "20",
            &gpx,
            "-o",
            out.to_str().unwrap(),
        ],
        None,
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let fc = json_file(&out);
    let f = fc["features"]
        .as_array()
        .unwrap()
        .iter()
        .find(|f| !f["geometry"].is_null())
        .unwrap();
    assert!(
        f["properties"]["fit"]["time"].is_object(),
        "fitted in time: {}",
        f["properties"]["fit"]
    );
}

/// The output features of `spherefit fit ARGS INPUT -o out.geojson`, and its stderr.
fn fit_geojson(args: &[&str], input: &str, dir: &Path, name: &str) -> (Vec<Value>, String) {
    let out = dir.join(format!("{name}.geojson"));
    let mut all = vec!["fit"];
    all.extend_from_slice(args);
    all.extend_from_slice(&[input, "-o", out.to_str().unwrap()]);
    let o = run_spherefit(&all, None);
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(o.status.success(), "{all:?}: {err}");
    let fc = json_file(&out);
    (fc["features"].as_array().unwrap().clone(), err)
}

fn metres_between(p: &[f64], q: &[f64]) -> f64 {
    let (a, b) = (lonlat_to_unit(p[0], p[1]), lonlat_to_unit(q[0], q[1]));
    let d: f64 = a
        .iter()
        .zip(&b)
        .map(|(x, y)| (x - y) * (x - y))
        .sum::<f64>()
        .sqrt();
    d * EARTH_RADIUS_M
}

#[test]
fn projected_copies_fit_like_the_lonlat_original() {
    let dir = scratch("crs");
    let args = ["--tolerance-m", "10"];
    let (want, _) = fit_geojson(
        &args,
        &fixture_path("gps_tracks_slovenia_gpxpy.geojson"),
        &dir,
        "lonlat",
    );
    for (file, crs) in [
        ("tracks_3857.gpkg", "EPSG:3857"),
        ("tracks_32633.shp", "EPSG:32633"),
    ] {
        let (got, err) = fit_geojson(&args, &fixture_path(&format!("formats/{file}")), &dir, file);
        assert!(
            err.contains(&format!("coordinates in {crs} transformed to lon/lat")),
            "{file}: {err}"
        );
        assert_eq!(got.len(), want.len());
        let mut worst = 0.0f64;
        for (g, w) in got.iter().zip(&want) {
            let (a, b) = (lines(&g["geometry"]), lines(&w["geometry"]));
            assert_eq!(a.len(), b.len());
            for (x, y) in a.iter().zip(&b) {
                assert_eq!(x.len(), y.len(), "{file}: same output points");
                for (p, q) in x.iter().zip(y) {
                    worst = worst.max(metres_between(p, q));
                }
            }
            let (e, f) = (&g["properties"]["fit"], &w["properties"]["fit"]);
            assert_eq!(e["control_points"], f["control_points"], "{file}");
            let de =
                (e["max_error_m"].as_f64().unwrap() - f["max_error_m"].as_f64().unwrap()).abs();
            assert!(de < 0.01, "{file}: max error differs by {de} m");
        }
        assert!(
            worst < 0.01,
            "{file}: output {worst} m from the lon/lat fit's"
        );
    }
}

#[test]
fn unknown_crs_and_truncated_files_are_refused_with_where() {
    let dir = scratch("bad");
    for ext in ["shp", "shx", "dbf", "cpg"] {
        std::fs::copy(
            fixture_path(&format!("formats/us_states.{ext}")),
            dir.join(format!("mars.{ext}")),
        )
        .unwrap();
    }
    std::fs::write(
        dir.join("mars.prj"),
        r#"PROJCS["Mars_Equidistant_Cylindrical",GEOGCS["GCS_Mars_2000",DATUM["D_Mars_2000",SPHEROID["Mars_2000_IAU_IAG",3396190.0,169.8944472236118]],PRIMEM["Reference_Meridian",0.0],UNIT["Degree",0.0174532925199433]],PROJECTION["Equidistant_Cylindrical"],UNIT["Meter",1.0]]"#,
    )
    .unwrap();
    let mars = dir.join("mars.shp");
    let o = run_spherefit(&["fit", mars.to_str().unwrap()], None);
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("Mars_Equidistant_Cylindrical") && err.contains("mars.shp"),
        "{err}"
    );

    // Truncated: the .shp in the middle of a record, the .dbf, a FlatGeobuf.
    let cases = [
        ("us_states.shp", 20_000usize, "record"),
        ("us_states.dbf", 1_000, "record"),
        ("us_states.fgb", 20_000, "record"),
        ("cerknicko-jezero.gpx", 20_000, "not a valid GPX"),
        ("world_atlas_countries_110m.topojson", 50_000, "byte"),
    ];
    for (file, keep, what) in cases {
        let sub = dir.join(file.replace('.', "_"));
        std::fs::create_dir_all(&sub).unwrap();
        let stem = file.split('.').next().unwrap();
        for ext in ["shp", "shx", "dbf", "prj", "cpg"] {
            let p = fixture_path(&format!("formats/{stem}.{ext}"));
            if Path::new(&p).exists() {
                std::fs::copy(&p, sub.join(format!("{stem}.{ext}"))).unwrap();
            }
        }
        let bytes = std::fs::read(fixture_path(&format!("formats/{file}"))).unwrap();
        let target = sub.join(file);
        std::fs::write(&target, &bytes[..keep]).unwrap();
        let input = if file.ends_with(".dbf") {
            sub.join(format!("{stem}.shp"))
        } else {
            target.clone()
        };
        let o = run_spherefit(
            &[
                "fit",
                "-q",
                input.to_str().unwrap(),
                "-o",
                sub.join("o.geojson").to_str().unwrap(),
            ],
            None,
        );
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{file}: {err}");
        assert!(err.contains(file) && err.contains(what), "{file}: {err}");
        if what == "record" {
            assert!(err.contains("byte"), "{file}: {err}");
        }
        assert!(!err.contains("panicked"), "{file}: {err}");
    }
}

/// The features of `path` as GDAL reads them (`ogr2ogr -f GeoJSON`), after checking with
/// `ogrinfo` that GDAL opens it with `driver`; None (with a notice) without GDAL.
fn gdal_read(path: &Path, driver: &str) -> Option<Vec<Value>> {
    gdal_read_layer(path, driver, None)
}

/// As [`gdal_read`], one layer (GeoJSON holds one: a GPX file's `tracks`, say).
fn gdal_read_layer(path: &Path, driver: &str, layer: Option<&str>) -> Option<Vec<Value>> {
    let info = match Command::new("ogrinfo")
        .args(["-ro", "-so", "-al"])
        .arg(path)
        .output()
    {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            assert!(
                !tools_required(),
                "ogrinfo (Debian gdal-bin) is not installed"
            );
            println!("NOTICE: ogrinfo (GDAL) is not installed: the GDAL half was skipped");
            return None;
        }
        Err(e) => panic!("ogrinfo: {e}"),
        Ok(o) => o,
    };
    let text = String::from_utf8_lossy(&info.stdout);
    let err = String::from_utf8_lossy(&info.stderr);
    assert!(
        info.status.success() && !err.contains("ERROR"),
        "ogrinfo {}: {err}",
        path.display()
    );
    assert!(text.contains(&format!("using driver `{driver}'")), "{text}");
    let o = Command::new("ogr2ogr")
        .args(["-f", "GeoJSON", "/vsistdout/"])
        .arg(path)
        .args(layer)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        o.status.success() && !err.contains("ERROR"),
        "ogr2ogr {}: {err}",
        path.display()
    );
    let fc: Value = serde_json::from_slice(&o.stdout).unwrap();
    Some(fc["features"].as_array().unwrap().clone())
}

/// `value` (as written) is what GDAL read back: numbers within a relative 1e-12.
fn close(a: &Value, b: &Value) -> bool {
    match (a, b) {
        (Value::Number(x), Value::Number(y)) => {
            let (x, y) = (x.as_f64().unwrap(), y.as_f64().unwrap());
            (x - y).abs() <= 1e-12 * x.abs().max(y.abs()).max(1.0)
        }
        (Value::Bool(x), Value::Number(y)) => y.as_i64() == Some(i64::from(*x)),
        _ => a == b,
    }
}

#[test]
fn written_files_are_read_back_by_gdal_and_by_spherefit() {
    let dir = scratch("write");
    let input = fixture_path("formats/us_states.shp");
    let args = ["-q", "--tolerance-m", "1000"];
    let (want, _) = fit_geojson(&args, &input, &dir, "reference");
    for (ext, driver) in [
        ("gpkg", "GPKG"),
        ("fgb", "FlatGeobuf"),
        ("shp", "ESRI Shapefile"),
    ] {
        let out = dir.join(format!("out.{ext}"));
        let o = run_spherefit(
            &[
                "fit",
                "-q",
                "--tolerance-m",
                "1000",
                &input,
                "-o",
                out.to_str().unwrap(),
            ],
            None,
        );
        assert!(
            o.status.success(),
            "{ext}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        // Read back by spherefit: every feature, position and property.
        let back = read_all(out.to_str().unwrap(), None);
        assert_eq!(back.len(), want.len(), "{ext}");
        let max_error = if ext == "shp" {
            "max_err_m"
        } else {
            "max_error_m"
        };
        for (b, w) in back.iter().zip(&want) {
            assert!(same_rings(&b["geometry"], &w["geometry"]), "{ext}");
            assert_eq!(b["properties"]["name"], w["properties"]["name"], "{ext}");
            assert!(
                close(
                    &b["properties"][max_error],
                    &w["properties"]["fit"]["max_error_m"]
                ),
                "{ext}: {}",
                b["properties"]
            );
            assert!(
                close(
                    &b["properties"]["stored_num"]
                        .as_i64()
                        .map_or(b["properties"]["stored_numbers"].clone(), Value::from),
                    &w["properties"]["fit"]["stored_numbers"]
                ),
                "{ext}"
            );
            if ext != "shp" {
                // The whole report, compact curve included, as JSON text.
                let fit: Value =
                    serde_json::from_str(b["properties"]["fit"].as_str().unwrap()).unwrap();
                assert_eq!(fit, w["properties"]["fit"], "{ext}");
            }
        }
        // Read back by GDAL.
        let Some(gdal) = gdal_read(&out, driver) else {
            continue;
        };
        assert_eq!(gdal.len(), want.len(), "{ext}");
        for (g, w) in gdal.iter().zip(&want) {
            assert!(
                same_rings(&g["geometry"], &w["geometry"]),
                "{ext}: {} vs {}",
                g["geometry"]["type"],
                w["geometry"]["type"]
            );
            assert_eq!(g["properties"]["name"], w["properties"]["name"]);
            assert!(
                close(
                    &g["properties"][max_error],
                    &w["properties"]["fit"]["max_error_m"]
                ),
                "{ext}: {}",
                g["properties"]
            );
        }
    }
    // GPX: tracks with their times from the curve (within 1 s of the GeoJSON output's).
    let gpx = fixture_path("formats/cerknicko-jezero.gpx");
    let args = ["-q", "--layer", "tracks", "--tolerance-m", "20"];
    let (want, _) = fit_geojson(&args, &gpx, &dir, "track");
    let out = dir.join("out.gpx");
    let mut all = vec!["fit"];
    all.extend_from_slice(&args);
    all.extend_from_slice(&[gpx.as_str(), "-o", out.to_str().unwrap()]);
    let o = run_spherefit(&all, None);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let back = read_all(out.to_str().unwrap(), Some("tracks"));
    assert_eq!(back.len(), want.len());
    for (b, w) in back.iter().zip(&want) {
        if w["geometry"].is_null() {
            assert!(b["geometry"].is_null());
            continue;
        }
        assert!(same_rings(&b["geometry"], &w["geometry"]));
        let bt = b["properties"]["coordTimes"].as_array().unwrap();
        let wt = w["properties"]["coordTimes"]
            .as_array()
            .expect("the output has times");
        assert_eq!(bt.len(), wt.len());
        for (x, y) in bt.iter().zip(wt) {
            let ts = |v: &Value| -> f64 {
                match v.as_f64() {
                    Some(s) => s,
                    None => {
                        v.as_str()
                            .unwrap()
                            .parse::<jiff::Timestamp>()
                            .unwrap()
                            .as_millisecond() as f64
                            / 1000.0
                    }
                }
            };
            assert!((ts(x) - ts(y)).abs() <= 1.0, "{x} vs {y}");
        }
    }
    if let Some(gdal) = gdal_read_layer(&out, "GPX", Some("tracks")) {
        assert_eq!(gdal.len(), want.len());
    }
}

#[test]
fn a_value_too_wide_for_a_dbf_field_is_an_error_not_a_cut() {
    let dir = scratch("dbf");
    let long = "x".repeat(300);
    let doc = serde_json::json!({"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {"note": long}, "geometry": {"type": "LineString", "coordinates": [[0.0, 0.0], [1.0, 1.0], [2.0, 0.5]]}}
    ]});
    let input = dir.join("in.geojson");
    std::fs::write(&input, doc.to_string()).unwrap();
    let out = dir.join("out.shp");
    let o = run_spherefit(
        &[
            "fit",
            "-q",
            input.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ],
        None,
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("feature 1") && err.contains("\"note\"") && err.contains("300 bytes"),
        "{err}"
    );
    assert!(!out.exists(), "no partial Shapefile is left");
    // The same feature goes into a GeoPackage whole.
    let out = dir.join("out.gpkg");
    let o = run_spherefit(
        &[
            "fit",
            "-q",
            input.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ],
        None,
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let back = read_all(out.to_str().unwrap(), None);
    assert_eq!(back[0]["properties"]["note"].as_str().unwrap().len(), 300);
}

/// Posts `body` with `content_type` (and `accept`) to `/v1/fit?QUERY` of a fresh router;
/// returns the status, the content type and the body bytes.
fn post_file(
    query: &str,
    content_type: &str,
    accept: Option<&str>,
    body: Vec<u8>,
) -> (u16, String, Vec<u8>) {
    use axum::body::Body;
    use axum::http::{header, Request};
    use spherefit::service::{router, AppState, ServiceConfig};
    use tower::ServiceExt;
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .unwrap();
    rt.block_on(async {
        let app = router(AppState::new(ServiceConfig::default()));
        let mut req = Request::builder()
            .method("POST")
            .uri(format!("/v1/fit?{query}"))
            .header(header::CONTENT_TYPE, content_type);
        if let Some(a) = accept {
            req = req.header(header::ACCEPT, a);
        }
        let res = app
            .oneshot(req.body(Body::from(body)).unwrap())
            .await
            .unwrap();
        let status = res.status().as_u16();
        let ct = res
            .headers()
            .get(header::CONTENT_TYPE)
            .map(|v| v.to_str().unwrap().to_string())
            .unwrap_or_default();
        let bytes = axum::body::to_bytes(res.into_body(), usize::MAX)
            .await
            .unwrap();
        (status, ct, bytes.to_vec())
    })
}

#[test]
fn the_service_fits_a_zipped_shapefile_and_answers_a_geopackage() {
    let zip = std::fs::read(fixture_path("formats/us_states.zip")).unwrap();
    let (status, ct, body) = post_file("tolerance_m=1000", "application/zip", None, zip.clone());
    assert_eq!(status, 200, "{}", String::from_utf8_lossy(&body));
    assert_eq!(ct, "application/geo+json");
    let fc: Value = serde_json::from_slice(&body).unwrap();
    let (cli, _) = fit_geojson(
        &["-q", "--tolerance-m", "1000"],
        &fixture_path("formats/us_states.zip"),
        &scratch("service"),
        "cli",
    );
    assert_eq!(
        fc["features"].as_array().unwrap(),
        &cli,
        "the service's features are the CLI's"
    );

    let (status, ct, body) = post_file(
        "tolerance_m=1000",
        "application/zip",
        Some("application/geopackage+sqlite3, application/geo+json;q=0.5"),
        zip.clone(),
    );
    assert_eq!(status, 200, "{}", String::from_utf8_lossy(&body));
    assert_eq!(ct, "application/geopackage+sqlite3");
    let dir = scratch("service-gpkg");
    let out = dir.join("answer.gpkg");
    std::fs::write(&out, &body).unwrap();
    let back = read_all(out.to_str().unwrap(), Some("features"));
    assert_eq!(back.len(), cli.len());
    for (b, w) in back.iter().zip(&cli) {
        assert!(same_rings(&b["geometry"], &w["geometry"]));
        assert!(close(
            &b["properties"]["max_error_m"],
            &w["properties"]["fit"]["max_error_m"]
        ));
    }
    if let Some(gdal) = gdal_read(&out, "GPKG") {
        assert_eq!(gdal.len(), cli.len());
    }

    // TopoJSON as JSON; a GeoPackage and a GPX body.
    let topo = std::fs::read(fixture_path("formats/world_atlas_countries_110m.topojson")).unwrap();
    let (status, _, body) = post_file("tolerance_m=10000", "application/json", None, topo);
    assert_eq!(status, 200, "{}", String::from_utf8_lossy(&body));
    let fc: Value = serde_json::from_slice(&body).unwrap();
    assert_eq!(fc["features"].as_array().unwrap().len(), 178);
    let gpkg = std::fs::read(fixture_path("formats/tracks_3857.gpkg")).unwrap();
    let (status, _, body) = post_file(
        "tolerance_m=10",
        "application/geopackage+sqlite3",
        None,
        gpkg,
    );
    assert_eq!(status, 200, "{}", String::from_utf8_lossy(&body));
    let gpx = std::fs::read(fixture_path("formats/cerknicko-jezero.gpx")).unwrap();
    let (status, _, body) = post_file("tolerance_m=20", "application/gpx+xml", None, gpx);
    assert_eq!(status, 200, "{}", String::from_utf8_lossy(&body));

    // A truncated zip: 400 naming what broke; not a zip at all: the same.
    let (status, ct, body) = post_file(
        "tolerance_m=1000",
        "application/zip",
        None,
        zip[..zip.len() / 2].to_vec(),
    );
    assert_eq!(status, 400, "{}", String::from_utf8_lossy(&body));
    assert_eq!(ct, "application/problem+json");
    let p: Value = serde_json::from_slice(&body).unwrap();
    assert_eq!(p["type"], "urn:spherefit:problem:unreadable-file");
    let (status, _, _) = post_file("", "application/flatgeobuf", None, b"not a file".to_vec());
    assert_eq!(status, 400);
}
