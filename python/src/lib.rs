//! `spherefit._native`: the Python extension module under the `spherefit` package.
//!
//! Thin on purpose: every geometry goes through [`spherefit::earth::process_geometry`] (or
//! [`spherefit::earth::process_feature`] for evaluation) with a [`Job`] built and validated as
//! the CLI builds it, so a feature gives the same numbers here as from `spherefit fit`. The
//! S^n functions call [`spherefit::sphere`] and write the documents of `spherefit sphere`.
//! Geometry crosses as WKB ([`wkb_io`]); the work runs with the GIL released, features in
//! parallel on the rayon pool.

mod wkb_io;

use pyo3::prelude::*;
use pyo3::types::{PyBool, PyBytes, PyDict};
use rayon::prelude::*;
use serde_json::{json, Value};
use spherefit::document::tolerance_document;
use spherefit::document::{
    curve_from_json, pointer_for, FitDocument, InterpolationDocument, SamplesDocument,
};
use spherefit::earth::coverage::fit_coverage;
use spherefit::earth::{
    into_job, process_feature, process_geometry, Document, EarthError, Job, Limits, OperationKind,
    Problem, RawOptions, Topology,
};
use spherefit::sphere::cancel::Cancel;
use spherefit::sphere::compare::{fit_with, CompareError, Method, MethodOptions};
use spherefit::sphere::curve::even_parameters;
use spherefit::sphere::fit::options_check::{check_given_together, check_tolerance_fit};
use spherefit::sphere::{
    fit, fit_to_tolerance, interpolate, BetaSolver, FitOptions, InputSite, InterpolationOptions,
    KnotPlacement, Parameterization, PointSet, Solver, SphereError, SphericalCurve, StepRule,
    ToleranceOptions,
};

// The GeoJSON functions take their options as keywords (`**options`) and hand them to
// `spherefit::earth::into_job`, which holds every default and rule; the literal limits in the
// signatures are the library's (checked in the tests below).

/// An error for Python: `spherefit.SpherefitError` (a `ValueError`) with the feature index,
/// the pointer and the problem's slug as attributes.
struct Failure {
    message: String,
    index: Option<usize>,
    pointer: Option<String>,
    problem: &'static str,
}

impl Failure {
    fn option(message: impl Into<String>) -> Failure {
        Failure {
            message: message.into(),
            index: None,
            pointer: None,
            problem: "invalid-option",
        }
    }

    fn into_py(self, py: Python<'_>) -> PyErr {
        let made = py
            .import("spherefit._errors")
            .and_then(|m| m.getattr("SpherefitError"))
            .and_then(|cls| {
                cls.call1((self.message.clone(), self.index, self.pointer, self.problem))
            });
        match made {
            Ok(obj) => PyErr::from_value(obj),
            Err(e) => e,
        }
    }
}

/// A feature's error: "feature 3 at /coordinates/17: ...".
fn feature_failure(index: usize, pointer: &str, problem: &'static str, message: String) -> Failure {
    let message = if pointer.is_empty() {
        format!("feature {index}: {message}")
    } else {
        format!("feature {index} at {pointer}: {message}")
    };
    Failure {
        message,
        index: Some(index),
        pointer: Some(pointer.to_string()),
        problem,
    }
}

fn parse<T: std::str::FromStr>(option: &str, value: &str) -> Result<T, Failure>
where
    T::Err: std::fmt::Display,
{
    value
        .parse()
        .map_err(|e| Failure::option(format!("{option}: {e}")))
}

/// The keywords of a GeoJSON function as [`RawOptions`]: each value (`None`: not given) is
/// written as a query parameter's text (`true`, `12`, `0.5`, `adaptive`) and read by
/// [`RawOptions::set`], so a keyword means here what its query parameter means to the service.
fn raw_options(options: Option<&Bound<'_, PyDict>>) -> Result<RawOptions, Failure> {
    let mut raw = RawOptions::default();
    let Some(options) = options else {
        return Ok(raw);
    };
    for (k, v) in options.iter() {
        let name: String = k
            .extract()
            .map_err(|_| Failure::option("options: keyword names are strings"))?;
        if v.is_none() {
            continue;
        }
        let text = if v.is_instance_of::<PyBool>() {
            v.extract::<bool>().map(|b| b.to_string()).ok()
        } else if let Ok(i) = v.extract::<i64>() {
            Some(i.to_string())
        } else if let Ok(f) = v.extract::<f64>() {
            Some(f.to_string())
        } else {
            v.extract::<String>().ok()
        };
        let text = text.ok_or_else(|| {
            Failure::option(format!(
                "{name}: expected a number, a string or a bool, got {}",
                v.get_type()
                    .name()
                    .map_or("another type".into(), |n| n.to_string())
            ))
        })?;
        raw.set(&name, &text)
            .map_err(|e| Failure::option(format!("{name}: {e}")))?;
    }
    Ok(raw)
}

/// The job of `kind` from its keywords, checked by [`into_job`].
fn job_of(
    kind: OperationKind,
    options: Option<&Bound<'_, PyDict>>,
    limits: Limits,
) -> Result<Job, Failure> {
    let raw = raw_options(options)?;
    let job = into_job(raw, kind, &limits).map_err(option_failure)?;
    // The `fit` column is read back alone (`evaluate` gets no geometry): a degree-1 spline
    // there keeps its control points instead of referring to the geometry's.
    Ok(job
        .splines_referring_to_geometry(false)
        .with_cancel(Cancel::new()))
}

/// An option the Earth layer refused, a count past its limit saying so.
fn option_failure(e: EarthError) -> Failure {
    match e.problem.option_message() {
        Some((option, message)) => {
            let limit = if matches!(e.problem, Problem::CountOutOfRange { .. }) {
                " (the limit)"
            } else {
                ""
            };
            Failure {
                problem: e.problem.slug(),
                ..Failure::option(format!("{option}: {message}{limit}"))
            }
        }
        None => Failure {
            problem: e.problem.slug(),
            ..Failure::option(e.problem.to_string())
        },
    }
}

/// One processed feature: `None` when it passed through unchanged; its WKB `None` when it has
/// no geometry (`carry=spline`: the curve is in the properties alone).
type Outcome = Option<(Option<Vec<u8>>, Value)>;

/// What Python gets back: output WKB (None and no properties: keep the input geometry; None
/// with properties: no geometry, as `carry=spline` writes), the operation's properties object
/// as JSON text, and its scalar fields as a dict, per feature.
type Columns = (
    Vec<Option<Py<PyBytes>>>,
    Vec<Option<String>>,
    Vec<Option<Py<PyDict>>>,
);

fn earth_error(index: usize, e: EarthError) -> Failure {
    feature_failure(index, &e.pointer, e.problem.slug(), e.problem.to_string())
}

/// Turns a processed Feature into its output geometry (as WKB) and properties object.
fn outcome(index: usize, feature: Value, key: &str) -> Result<Outcome, Failure> {
    let geometry = &feature["geometry"];
    let info = feature["properties"][key].clone();
    if geometry.is_null() {
        return Ok(Some((None, info)));
    }
    let wkb = wkb_io::write(geometry).map_err(|m| {
        feature_failure(
            index,
            "",
            "internal",
            format!("writing the output WKB: {m}"),
        )
    })?;
    Ok(Some((Some(wkb), info)))
}

/// Runs `one` on every input in parallel, with the GIL released; the first error in input order
/// is raised. The calling thread waits, taking the GIL back every 50 ms to run Python's signal
/// handlers: a Ctrl-C (KeyboardInterrupt) cancels `cancel`, which the fitters check, and is
/// raised once the workers have stopped.
fn run_all<I, F>(
    py: Python<'_>,
    inputs: Vec<Option<I>>,
    cancel: &Cancel,
    one: F,
) -> PyResult<Columns>
where
    I: Send + Sync,
    F: Fn(usize, &I) -> Result<Outcome, Failure> + Send + Sync,
{
    let (results, interrupt) = py.detach(|| {
        let (tx, rx) = std::sync::mpsc::channel();
        std::thread::scope(|scope| {
            scope.spawn(|| {
                let r: Vec<Result<Outcome, Failure>> = inputs
                    .par_iter()
                    .enumerate()
                    .map(|(i, x)| match x {
                        None => Ok(None),
                        Some(x) => one(i, x),
                    })
                    .collect();
                // The receiver outlives this scope, so the send cannot fail.
                let _ = tx.send(r);
            });
            let mut interrupt = None;
            loop {
                match rx.recv_timeout(std::time::Duration::from_millis(50)) {
                    Ok(r) => return (r, interrupt),
                    Err(std::sync::mpsc::RecvTimeoutError::Timeout) => {
                        if interrupt.is_none() {
                            if let Err(e) = Python::attach(|py| py.check_signals()) {
                                cancel.cancel();
                                interrupt = Some(e);
                            }
                        }
                    }
                    Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => {
                        // The worker panicked; the scope re-raises its panic on exit.
                        return (Vec::new(), interrupt);
                    }
                }
            }
        })
    });
    if let Some(e) = interrupt {
        return Err(e);
    }
    let outcomes = results
        .into_iter()
        .collect::<Result<Vec<_>, _>>()
        .map_err(|f| f.into_py(py))?;
    columns(py, outcomes)
}

/// The columns Python gets back for these outcomes.
fn columns(py: Python<'_>, outcomes: Vec<Outcome>) -> PyResult<Columns> {
    let mut geoms = Vec::with_capacity(outcomes.len());
    let mut infos = Vec::with_capacity(outcomes.len());
    let mut scalars = Vec::with_capacity(outcomes.len());
    for o in outcomes {
        match o {
            None => {
                geoms.push(None);
                infos.push(None);
                scalars.push(None);
            }
            Some((wkb, info)) => {
                geoms.push(wkb.map(|w| PyBytes::new(py, &w).unbind()));
                infos.push(Some(info.to_string()));
                scalars.push(Some(scalar_fields(py, &info)?.unbind()));
            }
        }
    }
    Ok((geoms, infos, scalars))
}

/// The top-level numbers, booleans and strings of a properties object.
fn scalar_fields<'py>(py: Python<'py>, info: &Value) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    if let Value::Object(m) = info {
        for (k, v) in m {
            match v {
                Value::Bool(b) => d.set_item(k, *b)?,
                Value::Number(n) => match (n.as_u64(), n.as_i64(), n.as_f64()) {
                    (Some(u), _, _) => d.set_item(k, u)?,
                    (None, Some(i), _) => d.set_item(k, i)?,
                    (None, None, Some(f)) => d.set_item(k, f)?,
                    _ => {}
                },
                Value::String(s) => d.set_item(k, s)?,
                _ => {}
            }
        }
    }
    Ok(d)
}

/// A fit's columns and, for `topology="shared"`, the coverage's `topology` member (the
/// dataset report and every arc's spline) as JSON text.
type FitColumns = (
    Vec<Option<Py<PyBytes>>>,
    Vec<Option<String>>,
    Vec<Option<Py<PyDict>>>,
    Option<String>,
);

/// One input row: its WKB and, when the row carries properties (the times of a track), those
/// as a JSON object's text.
type Row = (Vec<u8>, Option<String>);

/// A row's properties, parsed: a JSON object, or `null` when there are none.
fn row_properties(index: usize, props: Option<&str>) -> Result<Value, Failure> {
    let Some(text) = props else {
        return Ok(Value::Null);
    };
    match serde_json::from_str::<Value>(text) {
        Ok(v @ Value::Object(_)) => Ok(v),
        _ => Err(feature_failure(
            index,
            "/properties",
            "invalid-option",
            "the row's properties are not a JSON object".into(),
        )),
    }
}

/// The geometry of a WKB row as GeoJSON, `None` for one that passes through.
fn row_geometry(index: usize, wkb: &[u8]) -> Result<Option<Value>, Failure> {
    match wkb_io::read(wkb) {
        Ok(wkb_io::Input::Curves(g)) => Ok(Some(g)),
        Ok(wkb_io::Input::PassThrough) => Ok(None),
        Err(p) => {
            let slug = if p.pointer.is_empty() {
                "invalid-wkb"
            } else {
                "invalid-coordinate"
            };
            Err(feature_failure(index, &p.pointer, slug, p.message))
        }
    }
}

/// Fits (or interpolates) one row with `job`: its geometry alone, or as a Feature with its
/// properties (errors then point into the geometry as without them, or into `/properties`).
fn one_row(index: usize, row: &Row, job: &Job, key: &str) -> Result<Outcome, Failure> {
    let Some(geometry) = row_geometry(index, &row.0)? else {
        return Ok(None);
    };
    let properties = row_properties(index, row.1.as_deref())?;
    let done = if properties.is_null() {
        process_geometry(&geometry, "", job)
    } else {
        let feature = json!({"type": "Feature", "properties": properties, "geometry": geometry});
        process_feature(&feature, "", job).map_err(|e| {
            let pointer = match e.pointer.strip_prefix("/geometry") {
                Some(rest) => rest.to_string(),
                None => e.pointer.clone(),
            };
            EarthError { pointer, ..e }
        })
    }
    .map_err(|e| earth_error(index, e))?;
    if done.stats.curves == 0 {
        return Ok(None);
    }
    outcome(index, done.feature.into_value(), key)
}

/// The rows, each with its properties when given (one per row).
fn rows_with(
    wkbs: Vec<Option<Vec<u8>>>,
    properties: Option<Vec<Option<String>>>,
) -> Result<Vec<Option<Row>>, Failure> {
    let n = wkbs.len();
    let props = match properties {
        Some(p) if p.len() != n => {
            return Err(Failure::option(format!(
                "properties: {} items for {n} geometries",
                p.len()
            )))
        }
        Some(p) => p,
        None => vec![None; n],
    };
    Ok(wkbs
        .into_iter()
        .zip(props)
        .map(|(w, p)| w.map(|w| (w, p)))
        .collect())
}

/// Fits spherical B-splines to WKB lines and rings, as `spherefit fit` does: per row, or with
/// `topology="shared"` the polygons of all rows as one coverage. The options are the keywords
/// of `spherefit.fit` (query parameters of `POST /v1/fit`), checked by the library.
#[pyfunction]
#[pyo3(signature = (
    wkbs, *, properties=None, max_samples=100_000, max_control_points=10_000,
    max_iterations=1_000, **options
))]
fn fit_wkb(
    py: Python<'_>,
    wkbs: Vec<Option<Vec<u8>>>,
    properties: Option<Vec<Option<String>>>,
    max_samples: usize,
    max_control_points: usize,
    max_iterations: usize,
    options: Option<&Bound<'_, PyDict>>,
) -> PyResult<FitColumns> {
    let limits = Limits {
        max_control_points,
        max_samples,
        max_iterations,
    };
    let (job, rows) = job_of(OperationKind::Fit, options, limits)
        .and_then(|job| Ok((job, rows_with(wkbs, properties)?)))
        .map_err(|f| f.into_py(py))?;
    match job.topology {
        Topology::PerFeature => {
            let (g, i, s) = run_all(py, rows, &job.cancel, |i, r| one_row(i, r, &job, "fit"))?;
            Ok((g, i, s, None))
        }
        Topology::Shared => coverage(py, rows, &job),
    }
}

/// `/features/3/geometry/coordinates/1` -> (3, `/coordinates/1`).
fn feature_pointer(pointer: &str) -> (Option<usize>, String) {
    let Some(rest) = pointer.strip_prefix("/features/") else {
        return (None, pointer.to_string());
    };
    let (index, tail) = rest.split_once('/').unwrap_or((rest, ""));
    let tail = format!("/{tail}");
    let tail = tail.strip_prefix("/geometry").unwrap_or(&tail).to_string();
    (
        index.parse().ok(),
        if tail == "/" { String::new() } else { tail },
    )
}

/// The rows fitted as one coverage ([`fit_coverage`]): polygon rows rebuilt from shared arcs,
/// other rows fitted on their own.
fn coverage(py: Python<'_>, rows: Vec<Option<Row>>, job: &Job) -> PyResult<FitColumns> {
    let run = || -> Result<(Vec<Outcome>, String), Failure> {
        let mut features = Vec::with_capacity(rows.len());
        for (i, row) in rows.iter().enumerate() {
            let (geometry, properties) = match row {
                None => (Value::Null, Value::Null),
                Some(r) => (
                    row_geometry(i, &r.0)?.unwrap_or(Value::Null),
                    row_properties(i, r.1.as_deref())?,
                ),
            };
            features
                .push(json!({"type": "Feature", "properties": properties, "geometry": geometry}));
        }
        let fail = |e: EarthError| {
            let (index, pointer) = feature_pointer(&e.pointer);
            match index {
                Some(i) => earth_error(i, EarthError { pointer, ..e }),
                None => Failure {
                    problem: e.problem.slug(),
                    ..Failure::option(e.to_string())
                },
            }
        };
        let doc = Document::parse(
            json!({"type": "FeatureCollection", "features": features}),
            false,
        )
        .map_err(fail)?;
        let coverage = fit_coverage(doc, job).map_err(fail)?;
        let out_features = coverage.features.clone();
        let collection = coverage.into_feature_collection(job.carry);
        let mut outcomes = Vec::with_capacity(out_features.len());
        for (i, f) in out_features.into_iter().enumerate() {
            let has_fit = f["properties"].get("fit").is_some();
            outcomes.push(if has_fit && !f["geometry"].is_null() {
                outcome(i, f, "fit")?
            } else {
                None
            });
        }
        Ok((outcomes, collection["topology"].to_string()))
    };
    let (outcomes, topology) = py.detach(run).map_err(|f| f.into_py(py))?;
    let (geoms, infos, scalars) = columns(py, outcomes)?;
    Ok((geoms, infos, scalars, Some(topology)))
}

/// Interpolates WKB lines and rings with spherical Beta-splines, as `spherefit interpolate`;
/// the options are the keywords of `spherefit.interpolate`, checked by the library.
#[pyfunction]
#[pyo3(signature = (wkbs, *, max_samples=100_000, **options))]
fn interpolate_wkb(
    py: Python<'_>,
    wkbs: Vec<Option<Vec<u8>>>,
    max_samples: usize,
    options: Option<&Bound<'_, PyDict>>,
) -> PyResult<Columns> {
    let limits = Limits {
        max_samples,
        ..Limits::default()
    };
    let (job, rows) = job_of(OperationKind::Interpolate, options, limits)
        .and_then(|job| Ok((job, rows_with(wkbs, None)?)))
        .map_err(|f| f.into_py(py))?;
    run_all(py, rows, &job.cancel, |i, r| {
        one_row(i, r, &job, "interpolation")
    })
}

/// Samples stored curves (the JSON of `properties.fit` or `properties.interpolation`, as
/// `spherefit.fit` writes it) into dense geometry, or at times (`at`), as `spherefit evaluate`;
/// the options are the keywords of `spherefit.evaluate`, checked by the library.
#[pyfunction]
#[pyo3(signature = (
    docs, key="fit", *, max_samples=100_000, max_control_points=10_000, **options
))]
fn evaluate_json(
    py: Python<'_>,
    docs: Vec<Option<String>>,
    key: &str,
    max_samples: usize,
    max_control_points: usize,
    options: Option<&Bound<'_, PyDict>>,
) -> PyResult<Columns> {
    if key != "fit" && key != "interpolation" {
        return Err(
            Failure::option(format!("key: {key:?}: use \"fit\" or \"interpolation\"")).into_py(py),
        );
    }
    let limits = Limits {
        max_samples,
        max_control_points,
        ..Limits::default()
    };
    let job = job_of(OperationKind::Evaluate, options, limits).map_err(|f| f.into_py(py))?;
    let prefix = format!("/properties/{key}");
    run_all(py, docs, &job.cancel, |i, text| {
        let doc: Value = serde_json::from_str(text).map_err(|e| {
            feature_failure(
                i,
                "",
                "invalid-spline",
                format!("the {key} JSON is not valid JSON: {e}"),
            )
        })?;
        if !doc.is_object() {
            return Err(feature_failure(
                i,
                "",
                "invalid-spline",
                format!(
                    "the {key} JSON must be an object, as spherefit.fit or interpolate writes it"
                ),
            ));
        }
        let feature = json!({"type": "Feature", "properties": {key: doc}, "geometry": null});
        let done = process_feature(&feature, "", &job).map_err(|e| {
            let pointer = e
                .pointer
                .strip_prefix(&prefix)
                .unwrap_or(&e.pointer)
                .to_string();
            earth_error(i, EarthError { pointer, ..e })
        })?;
        outcome(i, done.feature.into_value(), "evaluation")
    })
}

/// Rows of an (m, d) array of little-endian f64 passed as bytes.
fn rows(data: &[u8], m: usize, d: usize) -> Result<Vec<Vec<f64>>, Failure> {
    if m.checked_mul(d).and_then(|n| n.checked_mul(8)) != Some(data.len()) {
        return Err(Failure::option(format!(
            "points: {} bytes for {m} x {d} numbers",
            data.len()
        )));
    }
    let values: Vec<f64> = data
        .chunks_exact(8)
        .map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes")))
        .collect();
    // Row by row, so that d = 0 gives m empty rows (refused by the library, naming row 0).
    Ok((0..m)
        .map(|i| values[i * d..(i + 1) * d].to_vec())
        .collect())
}

fn point_set(data: &[u8], m: usize, d: usize) -> Result<PointSet, Failure> {
    let rows = rows(data, m, d)?;
    PointSet::try_from_rows(&rows).map_err(|e| sphere_failure(pointer_for("/points", &e), e))
}

/// Where a math-core error is ([`SphereError::site`]): an option by its keyword, the
/// parameters, or a JSON pointer into the points.
fn place(e: &SphereError) -> String {
    match e.site() {
        InputSite::Field { name, .. } => name.to_string(),
        InputSite::Parameters => "parameters".to_string(),
        _ => pointer_for("/points", e),
    }
}

fn sphere_failure(pointer: String, e: SphereError) -> Failure {
    let message = format!("{pointer}: {e}");
    Failure {
        message,
        index: None,
        pointer: Some(pointer),
        problem: "invalid-points",
    }
}

/// Fits a spherical B-spline to the rows of an (m, d) array of unit vectors, as
/// `spherefit sphere fit`; returns its output document as JSON text.
#[pyfunction]
#[pyo3(signature = (
    data, m, d, parameters=None, *, control_points=None, degree=3, knots="geodesic",
    iterations=None, parameterization="chord", step="deng-lin", solver="gls-pia",
    target_max_error_rad=None, tolerance_rad=None, method="gls-pia"
))]
#[allow(clippy::too_many_arguments)]
fn sphere_fit(
    py: Python<'_>,
    data: Vec<u8>,
    m: usize,
    d: usize,
    parameters: Option<Vec<f64>>,
    control_points: Option<usize>,
    degree: usize,
    knots: &str,
    iterations: Option<usize>,
    parameterization: &str,
    step: &str,
    solver: &str,
    target_max_error_rad: Option<f64>,
    tolerance_rad: Option<f64>,
    method: &str,
) -> PyResult<String> {
    let run = || -> Result<String, Failure> {
        let parameterization = parse::<Parameterization>("parameterization", parameterization)?;
        let method = parse::<Method>("method", method)?;
        if method != Method::GlsPia {
            return method_fit(MethodFitArgs {
                data: &data,
                m,
                d,
                parameters: parameters.as_deref(),
                control_points,
                iterations,
                parameterization,
                method,
                only_gls_pia: [
                    ("degree", degree != 3),
                    ("knots", knots != "geodesic"),
                    ("step", step != "deng-lin"),
                    ("solver", solver != "gls-pia"),
                    ("target_max_error_rad", target_max_error_rad.is_some()),
                    ("tolerance_rad", tolerance_rad.is_some()),
                ],
            });
        }
        let mut options = FitOptions::default()
            .with_degree(degree)
            .with_knots(parse::<KnotPlacement>("knots", knots)?)
            .with_iterations(iterations.unwrap_or(spherefit::sphere::fit::DEFAULT_ITERATIONS))
            .with_parameterization(parameterization)
            .with_step(parse::<StepRule>("step", step)?)
            .with_solver(parse::<Solver>("solver", solver)?);
        options.control_points = control_points;
        spherefit::earth::check_target_max_error_rad(target_max_error_rad)
            .map_err(option_failure)?;
        // knots, iterations, step and solver have defaults here, so only these tell if given.
        let given = [
            ("control_points", control_points.is_some()),
            ("target_max_error_rad", target_max_error_rad.is_some()),
            ("tolerance_rad", tolerance_rad.is_some()),
        ];
        let given: Vec<&str> = given.iter().filter(|(_, g)| *g).map(|(n, _)| *n).collect();
        check_given_together(&given).map_err(|e| option_failure(e.into()))?;
        check_tolerance_fit(tolerance_rad).map_err(|e| option_failure(e.into()))?;
        options.target_max_error_rad = target_max_error_rad;
        let points = point_set(&data, m, d)?;
        if let Some(tolerance_rad) = tolerance_rad {
            let mut t = ToleranceOptions {
                parameterization,
                ..ToleranceOptions::default()
            };
            t.degrees.retain(|&p| p <= degree.max(1));
            let r = fit_to_tolerance(&points, parameters.as_deref(), tolerance_rad, &t)
                .map_err(|e| sphere_failure(place(&e), e))?;
            return Ok(tolerance_document(&r).to_string());
        }
        let report = fit(&points, parameters.as_deref(), &options)
            .map_err(|e| sphere_failure(place(&e), e))?;
        serde_json::to_string(&FitDocument::from(&report))
            .map_err(|e| Failure::option(format!("writing the document: {e}")))
    };
    py.detach(run).map_err(|f| f.into_py(py))
}

/// What `sphere_fit` hands to [`method_fit`].
struct MethodFitArgs<'a> {
    data: &'a [u8],
    m: usize,
    d: usize,
    parameters: Option<&'a [f64]>,
    control_points: Option<usize>,
    iterations: Option<usize>,
    parameterization: Parameterization,
    method: Method,
    /// The B-spline fit's options, and whether each was given (differs from its default).
    only_gls_pia: [(&'static str, bool); 6],
}

/// `sphere_fit(method=...)` for the methods the GLS-PIA paper compares itself with
/// (`spherefit::sphere::compare`), as `spherefit sphere fit --method`.
fn method_fit(a: MethodFitArgs<'_>) -> Result<String, Failure> {
    if let Some((name, _)) = a.only_gls_pia.iter().find(|(_, given)| *given) {
        return Err(Failure::option(format!(
            "{name}: applies to method=\"gls-pia\" only, not {:?}",
            a.method.name()
        )));
    }
    let points = point_set(a.data, a.m, a.d)?;
    let options = MethodOptions {
        control_points: a.control_points,
        iterations: a.iterations,
        gls_pia: FitOptions::default().with_parameterization(a.parameterization),
        ..MethodOptions::default()
    };
    let r = fit_with(a.method, &points, a.parameters, &options).map_err(|e| match e {
        CompareError::Sphere(e) => sphere_failure(place(&e), e),
        CompareError::InvalidOption { option, .. } => Failure::option(format!("{option}: {e}")),
        e => Failure {
            message: format!("/points: {e}"),
            index: None,
            pointer: Some("/points".into()),
            problem: "invalid-points",
        },
    })?;
    Ok(r.document().to_string())
}

/// Interpolates the rows of an (m, d) array with a spherical Beta-spline, as
/// `spherefit sphere interpolate`; returns its output document as JSON text.
#[pyfunction]
#[pyo3(signature = (data, m, d, *, beta1=vec![1.0], beta2=vec![0.0], solver="newton", max_iterations=None))]
#[allow(clippy::too_many_arguments)]
fn sphere_interpolate(
    py: Python<'_>,
    data: Vec<u8>,
    m: usize,
    d: usize,
    beta1: Vec<f64>,
    beta2: Vec<f64>,
    solver: &str,
    max_iterations: Option<usize>,
) -> PyResult<String> {
    let run = || -> Result<String, Failure> {
        let points = point_set(&data, m, d)?;
        let mut options = InterpolationOptions::default()
            .with_beta1_per_point(beta1)
            .with_beta2_per_point(beta2)
            .with_solver(parse::<BetaSolver>("solver", solver)?);
        options.max_iterations = max_iterations;
        let result = interpolate(&points, &options).map_err(|e| {
            let pointer = match e.site() {
                InputSite::Field {
                    name,
                    index: Some(i),
                } => format!("{name}/{i}"),
                _ => place(&e),
            };
            sphere_failure(pointer, e)
        })?;
        serde_json::to_string(&InterpolationDocument::from(&result))
            .map_err(|e| Failure::option(format!("writing the document: {e}")))
    };
    py.detach(run).map_err(|f| f.into_py(py))
}

/// Evaluates a curve document (a spline or Beta-spline document, or the output of `sphere_fit`
/// or `sphere_interpolate`) at `at`, or at `samples` evenly spaced parameters; returns the
/// parameters, the points as little-endian f64 bytes, and the dimension.
#[pyfunction]
#[pyo3(signature = (doc, samples=101, at=None))]
fn sphere_evaluate(
    py: Python<'_>,
    doc: &str,
    samples: usize,
    at: Option<Vec<f64>>,
) -> PyResult<(Vec<f64>, Py<PyBytes>, usize)> {
    const MAX_SAMPLES: usize = 10_000_000;
    let run = || -> Result<(Vec<f64>, Vec<u8>, usize), Failure> {
        let v: Value = serde_json::from_str(doc)
            .map_err(|e| Failure::option(format!("the curve document is not valid JSON: {e}")))?;
        let curve = curve_from_json(&v).map_err(|e| Failure {
            message: e.to_string(),
            index: None,
            pointer: Some(e.pointer.clone()),
            problem: "invalid-spline",
        })?;
        let ts = match at {
            Some(ts) => {
                if let Some(i) = ts.iter().position(|t| !t.is_finite()) {
                    return Err(Failure::option(format!(
                        "at: value {i} is not a finite number"
                    )));
                }
                ts
            }
            None if samples == 0 => {
                return Err(Failure::option("samples: 0 points: give at least 1"))
            }
            None if samples > MAX_SAMPLES => {
                return Err(Failure::option(format!(
                    "samples: {samples} is more than the {MAX_SAMPLES} points one call may return"
                )))
            }
            None => even_parameters(curve.domain(), samples),
        };
        let pts = curve.evaluate_many(&ts);
        let doc = SamplesDocument {
            parameters: ts,
            points: pts.to_rows(),
        };
        let bytes: Vec<u8> = doc
            .points
            .iter()
            .flatten()
            .flat_map(|x| x.to_le_bytes())
            .collect();
        Ok((doc.parameters, bytes, curve.dim()))
    };
    let (ts, bytes, dim) = py.detach(run).map_err(|f| f.into_py(py))?;
    Ok((ts, PyBytes::new(py, &bytes).unbind(), dim))
}

/// The extension module.
#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(fit_wkb, m)?)?;
    m.add_function(wrap_pyfunction!(interpolate_wkb, m)?)?;
    m.add_function(wrap_pyfunction!(evaluate_json, m)?)?;
    m.add_function(wrap_pyfunction!(sphere_fit, m)?)?;
    m.add_function(wrap_pyfunction!(sphere_interpolate, m)?)?;
    m.add_function(wrap_pyfunction!(sphere_evaluate, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use spherefit::earth::Limits;

    #[test]
    fn fit_defaults_are_the_services() {
        use spherefit::sphere::{FitOptions, KnotPlacement, Solver};
        let f = FitOptions::faithful();
        assert_eq!(
            (f.knots, f.solver, f.parameter_correction),
            (KnotPlacement::Adaptive, Solver::GlsPiaAccelerated, false)
        );
    }

    #[test]
    fn signature_limits_are_the_library_defaults() {
        let l = Limits::default();
        assert_eq!(
            (l.max_samples, l.max_control_points, l.max_iterations),
            (100_000, 10_000, 1_000)
        );
    }
}
