//! `spherefit fit | interpolate | evaluate`, run as the built binary on `fixtures/`: the same
//! features as the HTTP endpoints, files and stdin, the three formats, a text sequence GDAL
//! reads, a bad record in the middle of a stream, `--stats`, `--help`, order under parallel
//! fitting, and a closed output pipe.

use crate::helpers::{fixture_path, run_spherefit};
use serde_json::{json, Value};
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

const BORDER: &str = "us_mexico_border_natural_earth.geojson";
const TRACKS: &str = "batch_tracks.geojsons";
const BAD: &str = "batch_tracks_bad_records.geojsons";
const RS: char = '\u{1e}';

fn spherefit() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_spherefit"));
    c.current_dir(env!("CARGO_MANIFEST_DIR"));
    c
}

/// Runs the binary with `args`, feeding `stdin` if given.
fn run(args: &[&str], stdin: Option<&[u8]>) -> Output {
    run_spherefit(args, stdin)
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Runs a command that must exit 0 and returns its stdout.
fn run_ok(args: &[&str], stdin: Option<&[u8]>) -> Vec<u8> {
    let o = run(args, stdin);
    assert_eq!(o.status.code(), Some(0), "{args:?}: {}", stderr(&o));
    o.stdout
}

/// A fresh directory under the target dir for one test's files.
fn scratch(test: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("cli_batch_{test}"));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn json_of(bytes: &[u8]) -> Value {
    serde_json::from_slice(bytes)
        .unwrap_or_else(|e| panic!("not JSON ({e}): {}", String::from_utf8_lossy(bytes)))
}

/// The records of an RFC 8142 text sequence: each RS-prefixed and LF-terminated.
fn seq_records(bytes: &[u8]) -> Vec<Value> {
    let text = std::str::from_utf8(bytes).unwrap();
    assert!(
        text.is_empty() || text.starts_with(RS),
        "a sequence starts with RS"
    );
    text.split(RS)
        .skip(1)
        .map(|r| {
            assert!(r.ends_with('\n'), "each record ends with LF: {r:?}");
            json_of(r.as_bytes())
        })
        .collect()
}

/// The lines of newline-delimited output.
fn lines(bytes: &[u8]) -> Vec<Value> {
    std::str::from_utf8(bytes)
        .unwrap()
        .lines()
        .map(|l| json_of(l.as_bytes()))
        .collect()
}

/// What the HTTP service answers to POST `uri` with `body`.
fn service(uri: &str, body: &Value) -> Value {
    let (status, _, v) = crate::helpers::post_geo_oneshot(uri, body);
    assert_eq!(status, 200, "{uri}: {v}");
    v
}

fn read_fixture(name: &str) -> Vec<u8> {
    std::fs::read(fixture_path(name)).unwrap()
}

/// The features of the tracks fixture as one FeatureCollection.
fn tracks_collection() -> Value {
    json!({"type": "FeatureCollection", "features": seq_records(&read_fixture(TRACKS))})
}

#[test]
fn a_file_in_and_out_gives_what_the_service_gives() {
    let dir = scratch("file");
    let border: Value = json_of(&read_fixture(BORDER));
    for (cmd, args, uri) in [
        ("fit", vec![], "/v1/fit"),
        (
            "fit",
            vec![
                "--control-points",
                "20",
                "--degree",
                "2",
                "--samples",
                "150",
                "--precision",
                "5",
            ],
            "/v1/fit?control_points=20&degree=2&samples=150&precision=5",
        ),
        (
            "fit",
            vec!["--tolerance-m", "500", "--solver", "gauss-newton"],
            "/v1/fit?tolerance_m=500&solver=gauss-newton",
        ),
        (
            "interpolate",
            vec!["--beta2", "0.5"],
            "/v1/interpolate?beta2=0.5",
        ),
    ] {
        let out = dir.join(format!("{cmd}.geojson"));
        let mut a = vec![cmd, "fixtures/us_mexico_border_natural_earth.geojson", "-o"];
        a.push(out.to_str().unwrap());
        a.extend(args.iter().copied());
        let stdout = run_ok(&a, None);
        assert!(stdout.is_empty(), "with -o nothing goes to stdout");
        let cli = json_of(&std::fs::read(&out).unwrap());
        assert_eq!(cli["features"].as_array().unwrap().len(), 3);
        assert_eq!(cli, service(uri, &border), "{cmd} {args:?} against {uri}");
    }
    // Evaluating the CLI's own fit gives what the service's evaluation of it gives.
    let fitted = json_of(&std::fs::read(dir.join("fit.geojson")).unwrap());
    let evaluated = run_ok(
        &[
            "evaluate",
            dir.join("fit.geojson").to_str().unwrap(),
            "--spacing-m",
            "2000",
        ],
        None,
    );
    let evaluated = json_of(&evaluated);
    assert_eq!(evaluated, service("/v1/evaluate?spacing_m=2000", &fitted));
    assert!(
        evaluated["features"][0]["properties"]["evaluation"]["output_points"].as_u64() > Some(1000)
    );
}

#[test]
fn stdin_to_stdout_keeps_the_format_and_every_feature() {
    let expected = service("/v1/fit", &tracks_collection());
    let expected = expected["features"].as_array().unwrap();
    // A text sequence on stdin comes back as a text sequence, feature for feature.
    let out = run_ok(&["fit", "-q"], Some(&read_fixture(TRACKS)));
    assert_eq!(&seq_records(&out), expected);
    // So does `-`.
    let out = run_ok(&["fit", "-q", "-"], Some(&read_fixture(TRACKS)));
    assert_eq!(&seq_records(&out), expected);
    // Newline-delimited in, newline-delimited out.
    let text = String::from_utf8(read_fixture(TRACKS))
        .unwrap()
        .replace(RS, "");
    let out = run_ok(&["fit", "-q"], Some(text.as_bytes()));
    assert_eq!(&lines(&out), expected);
    // Converted on request; --format forces the input format (and so the output's).
    let out = run_ok(
        &["fit", "-q", "--output-format", "geojson"],
        Some(text.as_bytes()),
    );
    assert_eq!(json_of(&out)["features"].as_array().unwrap(), expected);
    let out = run_ok(&["fit", "-q", "--format", "lines"], Some(text.as_bytes()));
    assert_eq!(&lines(&out), expected);
    let out = run_ok(
        &["fit", "-q", "--format", "seq", "--output-format", "lines"],
        Some(&read_fixture(TRACKS)),
    );
    assert_eq!(&lines(&out), expected);
    // The pass-through Point is unchanged; the ids keep their order.
    let ids: Vec<&Value> = expected.iter().map(|f| &f["id"]).collect();
    assert_eq!(
        ids,
        [
            &json!("wave"),
            &json!(2),
            &json!(3),
            &json!(4),
            &json!(5),
            &json!(6)
        ]
    );
    assert_eq!(expected[2], seq_records(&read_fixture(TRACKS))[2]);
}

#[test]
fn a_collection_is_streamed_with_its_foreign_members() {
    let mut fc = tracks_collection();
    fc["name"] = json!("tracks");
    fc["bbox"] = json!([-180, -90, 180, 90]);
    // Put a member after "features" too: serde_json writes keys in order, so build the text.
    let text = format!(
        "{{\"name\":\"tracks\",\"bbox\":[-180,-90,180,90],\"type\":\"FeatureCollection\",\"features\":{},\"crs84\":true}}",
        fc["features"]
    );
    fc["crs84"] = json!(true);
    let out = json_of(&run_ok(&["fit", "-q"], Some(text.as_bytes())));
    assert_eq!(out, service("/v1/fit", &fc));
    assert_eq!(out["name"], "tracks");
    assert_eq!(out["crs84"], true);
    assert!(
        out.get("bbox").is_none(),
        "the stale bbox is dropped, as by the service"
    );
    // Two inputs make one output, in order.
    let dir = scratch("collection");
    let path = dir.join("tracks.geojson");
    std::fs::write(&path, &text).unwrap();
    let p = path.to_str().unwrap();
    let out = json_of(&run_ok(
        &[
            "fit",
            "-q",
            p,
            "fixtures/batch_tracks.geojsons",
            "--output-format",
            "geojson",
        ],
        None,
    ));
    let ids: Vec<Value> = out["features"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f["id"].clone())
        .collect();
    assert_eq!(ids.len(), 12);
    assert_eq!(ids[..6], ids[6..]);
}

/// `ogrinfo -ro -al -so PATH`, or `None` when GDAL is not installed.
fn ogrinfo(path: &Path) -> Option<String> {
    let o = Command::new("ogrinfo")
        .args(["-ro", "-al", "-so"])
        .arg(path)
        .output();
    match o {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => None,
        Err(e) => panic!("ogrinfo: {e}"),
        Ok(o) => {
            let text = format!("{}{}", stderr(&o), String::from_utf8_lossy(&o.stdout));
            assert!(o.status.success(), "ogrinfo failed: {text}");
            Some(text)
        }
    }
}

#[test]
fn a_text_sequence_round_trip_that_gdal_reads() {
    let dir = scratch("gdal");
    let fitted = dir.join("fitted.geojsons");
    let fitted_s = fitted.to_str().unwrap();
    run_ok(
        &[
            "fit",
            "-q",
            "--samples",
            "200",
            "fixtures/batch_tracks.geojsons",
            "-o",
            fitted_s,
        ],
        None,
    );
    let records = seq_records(&std::fs::read(&fitted).unwrap());
    assert_eq!(records.len(), 6);
    // Evaluating the stored splines gives the fitted geometries back.
    let evaluated = dir.join("evaluated.geojsons");
    run_ok(
        &[
            "evaluate",
            "-q",
            "--samples",
            "200",
            fitted_s,
            "-o",
            evaluated.to_str().unwrap(),
        ],
        None,
    );
    let again = seq_records(&std::fs::read(&evaluated).unwrap());
    assert_eq!(again.len(), 6);
    for (a, b) in records.iter().zip(&again) {
        let line_2d = a["geometry"]["type"] == "LineString"
            && a["geometry"]["coordinates"][0].as_array().map(Vec::len) == Some(2);
        if a["properties"]["fit"]["spline"].is_object() && line_2d {
            assert_eq!(a["geometry"], b["geometry"], "feature {}", a["id"]);
        }
    }
    let Some(info) = ogrinfo(&fitted) else {
        println!("NOTICE: ogrinfo (GDAL, Debian gdal-bin) is not installed: the GDAL half of this test was skipped");
        return;
    };
    for bad in ["ERROR", "FAILURE"] {
        assert!(!info.contains(bad), "ogrinfo reported {bad}: {info}");
    }
    assert!(
        info.contains("using driver `GeoJSONSeq' successful"),
        "{info}"
    );
    assert!(info.contains("Feature Count: 6"), "{info}");
    // Fields GDAL found in the fitted features: properties.fit is a JSON field.
    assert!(info.contains("fit: String(JSON)"), "{info}");
    assert!(info.contains("name: String"), "{info}");
    let info = ogrinfo(&evaluated).unwrap();
    assert!(
        !info.contains("ERROR") && info.contains("Feature Count: 6"),
        "{info}"
    );
    // And the other way: a sequence written by GDAL is read and fitted.
    let gdal_seq = dir.join("gdal.geojsons");
    let o = Command::new("ogr2ogr")
        .args(["-f", "GeoJSONSeq", "-lco", "RS=YES"])
        .arg(&gdal_seq)
        .arg(fixture_path(BORDER))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(std::fs::read(&gdal_seq).unwrap().starts_with(&[0x1e]));
    let out = run_ok(&["fit", "-q", gdal_seq.to_str().unwrap()], None);
    let features = seq_records(&out);
    assert_eq!(features.len(), 3);
    assert!(features
        .iter()
        .all(|f| f["properties"]["fit"]["max_error_m"].is_number()));
}

#[test]
fn a_bad_record_in_the_middle_is_reported_and_the_rest_written_in_order() {
    let o = run(&["fit", "fixtures/batch_tracks_bad_records.geojsons"], None);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    let ids: Vec<Value> = seq_records(&o.stdout)
        .iter()
        .map(|f| f["id"].clone())
        .collect();
    assert_eq!(
        ids,
        [
            json!("wave"),
            json!(2),
            json!(3),
            json!(4),
            json!(5),
            json!(6)
        ]
    );
    // The written features are exactly those of the good stream.
    assert_eq!(
        seq_records(&o.stdout),
        seq_records(&run_ok(
            &["fit", "-q", "fixtures/batch_tracks.geojsons"],
            None
        ))
    );
    let errors: Vec<&str> = err
        .lines()
        .filter(|l| l.starts_with("spherefit: ") && l.contains(": record "))
        .collect();
    assert_eq!(errors.len(), 2, "{err}");
    assert!(
        errors[0].contains(
            "batch_tracks_bad_records.geojsons: record 3: /geometry/coordinates/17/1: latitude 95"
        ),
        "{err}"
    );
    assert!(errors[1].contains("record 6: invalid JSON"), "{err}");
    assert!(err.contains("2 of 8 features failed"), "{err}");
    // Newline-delimited input names the line too, and -q keeps the errors.
    let text = String::from_utf8(read_fixture(BAD))
        .unwrap()
        .replace(RS, "\n");
    let o = run(&["fit", "-q", "--format", "lines"], Some(text.as_bytes()));
    assert_eq!(o.status.code(), Some(1));
    let err = stderr(&o);
    assert!(
        err.contains("stdin: record 3 (line 6): /geometry/coordinates/17/1"),
        "{err}"
    );
    assert_eq!(lines(&o.stdout).len(), 6);
}

#[test]
fn order_is_kept_when_records_finish_out_of_order() {
    // Big features first, then small ones: with 2 threads, later records finish first.
    let mut text = String::new();
    for i in 0..120 {
        let n = if i % 10 == 0 { 3000 } else { 20 };
        let coords: Vec<[f64; 2]> = (0..n)
            .map(|k| [i as f64 + 0.0005 * k as f64, (0.01 * k as f64).sin()])
            .collect();
        let f = json!({"type": "Feature", "id": i, "properties": null,
                       "geometry": {"type": "LineString", "coordinates": coords}});
        text.push(RS);
        text.push_str(&f.to_string());
        text.push('\n');
    }
    let out = run_ok(
        &["fit", "-q", "--threads", "2", "--samples", "50"],
        Some(text.as_bytes()),
    );
    let ids: Vec<u64> = seq_records(&out)
        .iter()
        .map(|f| f["id"].as_u64().unwrap())
        .collect();
    assert_eq!(ids, (0..120).collect::<Vec<u64>>());
}

#[test]
fn stats_are_json_with_the_totals() {
    let dir = scratch("stats");
    let o = run(&["fit", "--stats", "fixtures/batch_tracks.geojsons"], None);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let err = stderr(&o);
    let last = err.lines().last().unwrap();
    let stats = json_of(last.as_bytes());
    let features = seq_records(&o.stdout);
    let fitted: Vec<&Value> = features
        .iter()
        .filter(|f| f["properties"].get("fit").is_some())
        .collect();
    let input_points: u64 = fitted
        .iter()
        .map(|f| f["properties"]["fit"]["input_points"].as_u64().unwrap())
        .sum();
    let worst = fitted
        .iter()
        .map(|f| f["properties"]["fit"]["max_error_m"].as_f64().unwrap())
        .fold(0.0, f64::max);
    assert_eq!(stats["command"], "fit");
    assert_eq!(stats["records"], 6);
    assert_eq!(stats["features"], 6);
    assert_eq!(stats["features_with_curves"], 5);
    assert_eq!(stats["failed"], 0);
    assert_eq!(stats["curves"], 6, "MultiLineString has 2 parts");
    assert_eq!(stats["input_points"], input_points);
    assert!(
        (stats["max_error_m"].as_f64().unwrap() - worst).abs() < 1e-3,
        "{stats} vs {worst}"
    );
    let stored = stats["stored_numbers"].as_f64().unwrap();
    let ratio = stats["compression_ratio"].as_f64().unwrap();
    assert!((ratio - 2.0 * input_points as f64 / stored).abs() < 1e-12);
    assert!(ratio > 1.0);
    // The human summary is there too, unless --quiet.
    assert!(
        err.contains("6 features written (5 with curves), 0 failed"),
        "{err}"
    );
    // --stats=FILE with --quiet: nothing on stderr, the JSON in the file.
    let file = dir.join("stats.json");
    let arg = format!("--stats={}", file.display());
    let o = run(
        &[
            "fit",
            "-q",
            &arg,
            "fixtures/batch_tracks_bad_records.geojsons",
        ],
        None,
    );
    assert_eq!(o.status.code(), Some(1));
    let stats = json_of(&std::fs::read(&file).unwrap());
    assert_eq!(
        (stats["failed"].as_u64(), stats["features"].as_u64()),
        (Some(2), Some(6))
    );
    assert!(!stderr(&o).contains("features written"));
}

#[test]
fn help_reads_like_a_manual() {
    let fit = String::from_utf8(run_ok(&["fit", "--help"], None)).unwrap();
    for needle in [
        "Usage: spherefit fit [OPTIONS] [INPUT]...",
        "--control-points <N>",
        "a quarter of the distinct positions",
        "--degree <DEGREE>",
        "[default: 3]",
        "[default: adaptive]",
        "[default: 30]",
        "[default: chord]",
        "in metres",
        "Decimals of output degrees",
        "[default: 7]",
        "[default: 100000]",
        "RFC 8142",
        "Exit status: 0",
        "--threads <N>",
        "--stats[=<FILE>]",
        "[default: auto]",
    ] {
        assert!(fit.contains(needle), "fit --help lacks {needle:?}:\n{fit}");
    }
    let interpolate = String::from_utf8(run_ok(&["interpolate", "--help"], None)).unwrap();
    for needle in [
        "--beta1 <RATIO>",
        "[default: 1]",
        "--beta2 <TENSION>",
        "[default: 0]",
        "in metres",
    ] {
        assert!(
            interpolate.contains(needle),
            "interpolate --help lacks {needle:?}"
        );
    }
    let evaluate = String::from_utf8(run_ok(&["evaluate", "--help"], None)).unwrap();
    assert!(evaluate.contains("\"crs\": \"lonlat\"") && evaluate.contains("[default: 7]"));
    assert!(
        !evaluate.contains("--degree"),
        "evaluate takes no fit options"
    );
}

#[test]
fn a_closed_output_pipe_ends_quietly() {
    let dir = scratch("pipe");
    // Enough features that the output outgrows the pipe buffer many times over.
    let mut text = String::new();
    for i in 0..3000 {
        let coords: Vec<[f64; 2]> = (0..60)
            .map(|k| {
                [
                    0.01 * k as f64,
                    0.1 * i as f64 / 100.0 + 0.2 * (0.3 * k as f64).sin(),
                ]
            })
            .collect();
        let f = json!({"type": "Feature", "id": i, "properties": null,
                       "geometry": {"type": "LineString", "coordinates": coords}});
        text.push(RS);
        text.push_str(&f.to_string());
        text.push('\n');
    }
    let input = dir.join("many.geojsons");
    std::fs::write(&input, &text).unwrap();
    let stats = dir.join("stats.json");
    let mut child = spherefit()
        .args(["fit", "--samples", "500", input.to_str().unwrap()])
        .arg(format!("--stats={}", stats.display()))
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut first = [0u8; 4096];
    child
        .stdout
        .as_mut()
        .unwrap()
        .read_exact(&mut first)
        .unwrap();
    assert_eq!(first[0], 0x1e);
    drop(child.stdout.take()); // like `| head -c 4096`
    let o = child.wait_with_output().unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert_eq!(
        stderr(&o),
        "",
        "a closed pipe is not an error and prints nothing"
    );
    let s = json_of(&std::fs::read(&stats).unwrap());
    assert_eq!(s["output_closed"], true);
    assert!(
        s["features"].as_u64().unwrap() < 3000,
        "it stopped early: {s}"
    );
}

/// Arguments, stdin and a string stderr must contain.
type Case<'a> = (&'a [&'a str], Option<&'a [u8]>, &'a str);

#[test]
fn usage_and_unreadable_input_exit_2() {
    let cases: [Case; 7] = [
        (
            &["fit", "--degree", "9", "fixtures/batch_tracks.geojsons"],
            None,
            "--degree: degree 9",
        ),
        (
            &["fit", "--samples", "1", "fixtures/batch_tracks.geojsons"],
            None,
            "--samples",
        ),
        (
            &[
                "interpolate",
                "--beta1",
                "0",
                "fixtures/batch_tracks.geojsons",
            ],
            None,
            "--beta1",
        ),
        (
            &["fit", "--spacing-s", "10", "--samples", "5"],
            Some(b"".as_slice()),
            "--spacing-s: --spacing-s excludes --samples",
        ),
        (
            &["fit", "fixtures/no_such_file.geojson"],
            None,
            "no_such_file.geojson",
        ),
        (
            &["fit"],
            Some(b"{\"type\": \"FeatureCollection\", \"features\": [\n{\"type\":".as_slice()),
            "not a valid GeoJSON document",
        ),
        (&["fit", "-", "-"], Some(b"".as_slice()), "only once"),
    ];
    for (args, stdin, needle) in cases {
        let o = run(args, stdin);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(needle), "{args:?}: {}", stderr(&o));
    }
    // The output may not overwrite an input.
    let o = run(
        &[
            "fit",
            "fixtures/batch_tracks.geojsons",
            "-o",
            "fixtures/batch_tracks.geojsons",
        ],
        None,
    );
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("overwrite"));
    assert!(!read_fixture(TRACKS).is_empty());
}

#[test]
fn nothing_to_fit_passes_through_with_a_warning() {
    let points = b"{\"type\":\"Feature\",\"properties\":{\"a\":1},\"geometry\":{\"type\":\"Point\",\"coordinates\":[1,2]}}\n";
    let o = run(&["fit"], Some(points.as_slice()));
    assert_eq!(o.status.code(), Some(0));
    let out = json_of(&o.stdout);
    assert_eq!(out["features"][0]["properties"], json!({"a": 1}));
    assert!(
        stderr(&o).contains("warning: the input holds no LineString"),
        "{}",
        stderr(&o)
    );
    let o = run(&["fit"], Some(b"".as_slice()));
    assert_eq!(o.status.code(), Some(0));
    assert!(o.stdout.is_empty());
    assert!(stderr(&o).contains("no records"));
}

/// A leading UTF-8 byte order mark is skipped, as the service skips it: through stdin (the
/// streamed reader, the format probe) and from a file (read whole), detected or forced.
#[test]
fn a_leading_byte_order_mark_is_skipped_on_stdin_and_in_files() {
    let dir = scratch("bom");
    let doc = serde_json::to_vec(&tracks_collection()).unwrap();
    let bom = |b: &[u8]| [&b"\xef\xbb\xbf"[..], b].concat();
    let plain = run_ok(&["fit", "--tolerance-m", "50", "-"], Some(&doc));
    assert_eq!(json_of(&plain)["features"].as_array().unwrap().len(), 6);
    let path = dir.join("bom.geojson");
    std::fs::write(&path, bom(&doc)).unwrap();
    let file = path.to_str().unwrap();
    for (args, stdin) in [
        (vec!["fit", "--tolerance-m", "50", "-"], Some(bom(&doc))),
        (
            vec!["fit", "--tolerance-m", "50", "--format", "geojson", "-"],
            Some(bom(&doc)),
        ),
        (vec!["fit", "--tolerance-m", "50", file], None),
        (
            vec!["fit", "--tolerance-m", "50", "--format", "geojson", file],
            None,
        ),
    ] {
        let out = run_ok(&args, stdin.as_deref());
        assert_eq!(out, plain, "{args:?}");
    }
    // A text sequence after a BOM is still told apart (and written as one).
    let seq = read_fixture(TRACKS);
    let plain = run_ok(&["fit", "--tolerance-m", "50", "-"], Some(&seq));
    let out = run_ok(&["fit", "--tolerance-m", "50", "-"], Some(&bom(&seq)));
    assert_eq!(seq_records(&out).len(), 6);
    assert_eq!(out, plain);
}

/// A FeatureCollection whose third feature is cut short: two features, then broken JSON.
fn collection_cut_short() -> Vec<u8> {
    let f = seq_records(&read_fixture(TRACKS));
    let mut text = format!(
        "{{\"type\": \"FeatureCollection\", \"features\": [\n{},\n{},\n",
        f[0], f[1]
    );
    let third = f[2].to_string();
    text.push_str(&third[..third.len() / 2]);
    text.into_bytes()
}

/// A fatal error mid-document (JSON syntax) exits 2 and leaves nothing that looks complete: on
/// stdout no closing bracket, with `-o` no file (an existing one untouched, no temporary file
/// left). Per-record failures are not fatal: the rest is still written to the file.
#[test]
fn a_document_cut_short_leaves_no_output_that_looks_complete() {
    let dir = scratch("cut_short");
    let text = collection_cut_short();
    let path = dir.join("cut.geojson");
    std::fs::write(&path, &text).unwrap();
    let input = path.to_str().unwrap().to_string();
    // Streamed from stdin, and read whole from the file.
    for (args, stdin) in [
        (vec!["fit", "-"], Some(text.as_slice())),
        (vec!["fit", input.as_str()], None),
    ] {
        let o = run(&args, stdin);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains("not a valid GeoJSON document"));
        let out = String::from_utf8(o.stdout).unwrap();
        assert!(out.contains("\"features\""), "{args:?}: {out}");
        assert!(
            serde_json::from_str::<Value>(&out).is_err(),
            "{args:?}: the output parses as complete: {out}"
        );
        // The features before the error are there, the collection's `]}` is not.
        assert!(out.contains("\"id\":2"), "{args:?}: {out}");
        assert!(!out.trim_end().ends_with("]}"), "{args:?}: {out}");
    }
    let out = dir.join("out.geojson");
    let out_s = out.to_str().unwrap();
    let o = run(&["fit", input.as_str(), "-o", out_s], None);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(!out.exists(), "a cut-short run wrote {out_s}");
    std::fs::write(&out, b"old").unwrap();
    let o = run(&["fit", "-", "-o", out_s], Some(&text));
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert_eq!(std::fs::read(&out).unwrap(), b"old");
    let names: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    let mut sorted = names.clone();
    sorted.sort();
    assert_eq!(
        sorted,
        ["cut.geojson", "out.geojson"],
        "left behind: {names:?}"
    );
    // Bad records (exit 1) are reported and the others written: the file replaces the old one.
    let o = run(&["fit", &fixture_path(BAD), "-o", out_s], None);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert_eq!(seq_records(&std::fs::read(&out).unwrap()).len(), 6);
    // A whole run writes the file too.
    let o = run(&["fit", &fixture_path(TRACKS), "-o", out_s], None);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert_eq!(seq_records(&std::fs::read(&out).unwrap()).len(), 6);
}

#[test]
fn a_named_file_with_no_json_value_is_refused_and_empty_stdin_is_an_empty_stream() {
    let dir = scratch("no_json_value");
    for (name, bytes) in [
        ("empty.geojson", &b""[..]),
        ("bom.json", &b"\xef\xbb\xbf \n"[..]),
    ] {
        let path = dir.join(name);
        std::fs::write(&path, bytes).unwrap();
        let p = path.to_str().unwrap();
        let out = run(&["fit", p], None);
        assert_eq!(out.status.code(), Some(2), "{name}: {}", stderr(&out));
        assert!(out.stdout.is_empty(), "{name}");
        assert!(
            stderr(&out).contains("holds no JSON value"),
            "{}",
            stderr(&out)
        );
        let out = run(&["fit", "--format", "lines", p], None);
        assert_eq!(out.status.code(), Some(0), "{name}: {}", stderr(&out));
    }
    let out = run(&["fit", "-q", "-"], Some(b""));
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    assert!(out.stdout.is_empty());
}

#[test]
fn lines_and_rings_inside_a_geometry_collection_are_checked_like_the_fitted_ones() {
    // GDAL's t45: a one-position LineString in a GeometryCollection is not valid GeoJSON.
    for (geometry, pointer, why) in [
        (
            json!({"type": "GeometryCollection", "geometries": [
                {"type": "Point", "coordinates": [0, 1]},
                {"type": "LineString", "coordinates": [[0, 1]]}]}),
            "/geometries/1/coordinates",
            "a curve needs at least 2",
        ),
        (
            json!({"type": "GeometryCollection", "geometries": [
                {"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [0, 1]]]}]}),
            "/geometries/0/coordinates/0",
            "at least 4 positions",
        ),
        (
            json!({"type": "GeometryCollection", "geometries": [
                {"type": "MultiPolygon", "coordinates": [[[[0, 0], [1, 0], [0, 1], [0, 2]]]]}]}),
            "/geometries/0/coordinates/0/0/3",
            "must end where it starts",
        ),
    ] {
        let out = run(&["fit", "-"], Some(geometry.to_string().as_bytes()));
        assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
        let e = stderr(&out);
        assert!(e.contains(pointer) && e.contains(why), "{e}");
    }
}

/// `-o` through a symbolic link writes the file it points to and leaves the link a link (a
/// rename into place would replace the link, or a device such as `/dev/null`, with a file).
#[test]
fn output_through_a_symbolic_link_writes_its_target() {
    let dir = scratch("symlink_output");
    let target = dir.join("target.geojson");
    let link = dir.join("link.geojson");
    std::os::unix::fs::symlink(&target, &link).unwrap();
    let input = crate::helpers::fixture_path("us_mexico_border_natural_earth.geojson");
    let o = run_spherefit(
        &[
            "fit",
            "-q",
            "--tolerance-m",
            "100",
            &input,
            "-o",
            link.to_str().unwrap(),
        ],
        None,
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(std::fs::symlink_metadata(&link)
        .unwrap()
        .file_type()
        .is_symlink());
    let written = json_of(&std::fs::read(&target).unwrap());
    assert_eq!(written["features"].as_array().unwrap().len(), 3);
    // Nothing left beside it.
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 2);
}
