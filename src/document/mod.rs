//! The spline document: the one serialised form of a spherical B-spline, used by the CLI, the
//! service and files alike: `{"degree": 3, "knots": [...], "control_points": [[x, y, z], ...]}`
//! with unit-vector control points; and the other S^n JSON documents shared by the CLI and the
//! HTTP service (points in, fit results out), parsed with errors that carry a JSON pointer.

pub mod beta;

pub use beta::{beta_from_json, curve_from_json, BetaDocument, InterpolationDocument};

use crate::sphere::curve::bspline::SphericalBSpline;
use crate::sphere::fit::options::{FitReport, IterationError};
use crate::sphere::geometry::point::PointSet;
use crate::sphere::{InputSite, SphereError};
use serde::{Deserialize, Serialize};
use serde_json::Value;

/// A spherical B-spline as JSON. Decoding validates it ([`SphericalBSpline::try_new`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SplineDocument {
    /// Optional tag; `"bspline"` when present.
    #[serde(rename = "type", default, skip_serializing_if = "Option::is_none")]
    pub kind: Option<String>,
    /// Polynomial degree, 1 to 5.
    pub degree: usize,
    /// Clamped knot vector, `control_points + degree + 1` values.
    pub knots: Vec<f64>,
    /// Control points as unit vectors.
    pub control_points: Vec<Vec<f64>>,
}

/// A document that does not describe a valid spline, with the field at fault.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{field}: {source}")]
pub struct DocumentError {
    /// `degree`, `knots`, `control_points` or `type`.
    pub field: &'static str,
    /// What is wrong.
    pub source: SphereError,
}

impl From<&SphericalBSpline> for SplineDocument {
    fn from(s: &SphericalBSpline) -> Self {
        SplineDocument {
            kind: None,
            degree: s.degree(),
            knots: s.knots().to_vec(),
            control_points: s.control_points().to_rows(),
        }
    }
}

impl SplineDocument {
    /// Validates the document and builds the spline.
    ///
    /// # Errors
    /// A [`DocumentError`] naming the field (and, inside it, the index) at fault.
    pub fn try_into_spline(&self) -> Result<SphericalBSpline, DocumentError> {
        if let Some(kind) = &self.kind {
            if kind != "bspline" {
                return Err(DocumentError {
                    field: "type",
                    source: SphereError::InvalidKnots {
                        reason: format!("unknown spline type {kind:?} (expected \"bspline\")"),
                    },
                });
            }
        }
        let control =
            PointSet::try_from_rows(&self.control_points).map_err(|source| DocumentError {
                field: "control_points",
                source,
            })?;
        SphericalBSpline::try_new(self.degree, self.knots.clone(), control).map_err(|source| {
            let field = match source.site() {
                InputSite::Field { name, .. } => name,
                _ => "control_points",
            };
            DocumentError { field, source }
        })
    }
}

/// Input that cannot be used, with an RFC 6901 JSON pointer to the offending value
/// (`/points/3/1`) and the reason.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{}: {message}", if pointer.is_empty() { "(document)" } else { pointer.as_str() })]
pub struct InputError {
    /// JSON pointer into the input document ("" for the whole document).
    pub pointer: String,
    /// What is wrong there.
    pub message: String,
}

impl InputError {
    /// An error at `pointer`.
    pub fn at(pointer: impl Into<String>, message: impl Into<String>) -> InputError {
        InputError {
            pointer: pointer.into(),
            message: message.into(),
        }
    }
}

/// The pointer into a list of points (`base`, e.g. `/points`) that a [`SphereError`] names:
/// the point (`/points/3`) or its coordinate (`/points/3/1`), else `base` itself.
pub fn pointer_for(base: &str, e: &SphereError) -> String {
    match e.site() {
        site @ InputSite::Point { .. } => pointer(site, "", base),
        _ => base.to_string(),
    }
}

/// The JSON pointer of an [`InputSite`] in a document whose fields are below `doc` and whose
/// points are the array at `points`: `{doc}/beta1/2`, `{doc}/parameters`, `{points}/3/1`,
/// `{points}`; `doc` itself for [`InputSite::Nothing`].
pub fn pointer(site: InputSite, doc: &str, points: &str) -> String {
    match site {
        InputSite::Field { name, index: None } => format!("{doc}/{name}"),
        InputSite::Field {
            name,
            index: Some(i),
        } => format!("{doc}/{name}/{i}"),
        InputSite::Parameters => format!("{doc}/parameters"),
        InputSite::Point { index, coord: None } => format!("{points}/{index}"),
        InputSite::Point {
            index,
            coord: Some(c),
        } => format!("{points}/{index}/{c}"),
        InputSite::Points => points.to_string(),
        InputSite::Nothing => doc.to_string(),
    }
}

/// Points on S^n with optional caller-given parameters: `{"points": [[...], ...],
/// "parameters": [...]}` or a bare array of points.
#[derive(Clone, Debug, PartialEq)]
pub struct PointsInput {
    /// Validated unit vectors.
    pub points: PointSet,
    /// One parameter per point (timestamps, for example), if given.
    pub parameters: Option<Vec<f64>>,
    /// Where the points are in the document: `/points`, or `""` for a bare array.
    pub points_pointer: &'static str,
}

impl PointsInput {
    /// Parses and validates; errors point at the offending value.
    pub fn from_json(v: &Value) -> Result<PointsInput, InputError> {
        let (points_v, base, params_v) = match v {
            Value::Array(_) => (v, "", None),
            Value::Object(map) => {
                if let Some(k) = map.keys().find(|k| *k != "points" && *k != "parameters") {
                    return Err(InputError::at(
                        format!("/{k}"),
                        "unknown field: expected \"points\" and optionally \"parameters\"",
                    ));
                }
                let pv = map.get("points").ok_or_else(|| {
                    InputError::at("", "missing field \"points\" (an array of unit vectors)")
                })?;
                (
                    pv,
                    "/points",
                    map.get("parameters").filter(|p| !p.is_null()),
                )
            }
            _ => {
                return Err(InputError::at(
                    "",
                    "expected an array of points or an object with \"points\"",
                ))
            }
        };
        let rows = number_rows(points_v, base)?;
        let points = PointSet::try_from_rows(&rows)
            .map_err(|e| InputError::at(pointer_for(base, &e), e.to_string()))?;
        let parameters = match params_v {
            Some(p) => Some(number_list(p, "/parameters")?),
            None => None,
        };
        Ok(PointsInput {
            points,
            parameters,
            points_pointer: base,
        })
    }
}

/// An array of arrays of numbers, with a pointer to the first value that is not.
pub fn number_rows(v: &Value, base: &str) -> Result<Vec<Vec<f64>>, InputError> {
    let rows = v
        .as_array()
        .ok_or_else(|| InputError::at(base, "expected an array of points"))?;
    rows.iter()
        .enumerate()
        .map(|(i, row)| number_list(row, &format!("{base}/{i}")))
        .collect()
}

/// An array of numbers, with a pointer to the first value that is not.
pub fn number_list(v: &Value, base: &str) -> Result<Vec<f64>, InputError> {
    let items = v
        .as_array()
        .ok_or_else(|| InputError::at(base, "expected an array of numbers"))?;
    items
        .iter()
        .enumerate()
        .map(|(k, x)| {
            x.as_f64()
                .ok_or_else(|| InputError::at(format!("{base}/{k}"), "expected a number"))
        })
        .collect()
}

/// Errors of a fit as reported in documents.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct FitMetricsDocument {
    /// Largest geodesic error at the data parameters, radians.
    pub max_error_rad: f64,
    /// Mean geodesic error, radians.
    pub mean_error_rad: f64,
    /// Root-mean-square geodesic error, radians.
    pub rms_error_rad: f64,
    /// Iterations run.
    pub iterations: usize,
    /// Whether the fit stopped by its own criterion rather than the iteration limit.
    pub converged: bool,
}

/// The result of `sphere fit`: the spline, the data parameters, the error metrics and the
/// per-iteration history.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FitDocument {
    /// The fitted spline.
    pub spline: SplineDocument,
    /// The solver that made the curve.
    #[serde(default)]
    pub solver: crate::sphere::Solver,
    /// The data parameter of each point, in the spline's domain.
    pub parameters: Vec<f64>,
    /// Errors of the returned spline.
    pub metrics: FitMetricsDocument,
    /// Errors per iteration (index 0: the initial curve).
    pub history: Vec<IterationError>,
}

impl From<&FitReport> for FitDocument {
    fn from(r: &FitReport) -> Self {
        FitDocument {
            spline: SplineDocument::from(&r.spline),
            solver: r.solver,
            parameters: r.parameters.clone(),
            metrics: FitMetricsDocument {
                max_error_rad: r.metrics.max_error_rad,
                mean_error_rad: r.metrics.mean_error_rad,
                rms_error_rad: r.metrics.rms_error_rad,
                iterations: r.iterations,
                converged: r.converged,
            },
            history: r.history.clone(),
        }
    }
}

/// Points sampled from a curve: `{"parameters": [...], "points": [[...], ...]}`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SamplesDocument {
    /// The parameters sampled.
    pub parameters: Vec<f64>,
    /// The curve's point (a unit vector) at each parameter.
    pub points: Vec<Vec<f64>>,
}

/// Reads a spline document, or a fit result holding one under `"spline"`.
pub fn spline_from_json(v: &Value) -> Result<SphericalBSpline, InputError> {
    let (doc_v, base) = match v.get("spline") {
        Some(s) => (s, "/spline"),
        None => (v, ""),
    };
    let doc: SplineDocument = serde_json::from_value(doc_v.clone()).map_err(|e| {
        InputError::at(
            base,
            format!("not a spline document ({{\"degree\", \"knots\", \"control_points\"}}): {e}"),
        )
    })?;
    doc.try_into_spline().map_err(|e| {
        let field = format!("{base}/{}", e.field);
        InputError::at(pointer_for(&field, &e.source), e.to_string())
    })
}

/// The document of a tolerance fit (`sphere fit --tolerance-rad`, `POST /v1/sphere/fit?tolerance_rad=`):
/// `{"spline", "parameters", "metrics": {max, mean, rms error in radians}, "tolerance":
/// {"tolerance_rad", "tolerance_met", "two_way_distance_rad", "curve_length_ratio", "degree",
/// "knot_rule", "stored_numbers", "input_numbers", "compression_ratio"}}`.
pub fn tolerance_document(
    r: &crate::sphere::compress::tolerance::ToleranceFit,
) -> serde_json::Value {
    serde_json::json!({
        "spline": SplineDocument::from(&r.spline),
        "parameters": r.parameters,
        "metrics": {
            "max_error_rad": r.metrics.max_error_rad,
            "mean_error_rad": r.metrics.mean_error_rad,
            "rms_error_rad": r.metrics.rms_error_rad,
        },
        "tolerance": {
            "tolerance_rad": r.tolerance_rad,
            "tolerance_met": r.tolerance_met,
            "two_way_distance_rad": r.two_way_rad,
            "curve_length_ratio": r.curve_length_ratio,
            "degree": r.degree,
            "knot_rule": r.knot_rule,
            "stored_numbers": r.stored_numbers,
            "input_numbers": r.input_numbers,
            "compression_ratio": r.compression_ratio,
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips_through_json() {
        let json = r#"{"degree":1,"knots":[0,0,1,1],"control_points":[[1,0,0],[0,1,0]]}"#;
        let doc: SplineDocument = serde_json::from_str(json).unwrap();
        let s = doc.try_into_spline().unwrap();
        let text = serde_json::to_string(&SplineDocument::from(&s)).unwrap();
        let back: SplineDocument = serde_json::from_str(&text).unwrap();
        assert_eq!(back, doc);
    }

    #[test]
    fn errors_name_the_field() {
        let doc: SplineDocument = serde_json::from_str(
            r#"{"degree":1,"knots":[0,0,1,1],"control_points":[[1,0,0],[0,2,0]]}"#,
        )
        .unwrap();
        let e = doc.try_into_spline().unwrap_err();
        assert_eq!(e.field, "control_points");
        assert!(e.to_string().contains("point 1"), "{e}");
        let doc: SplineDocument = serde_json::from_str(
            r#"{"degree":1,"knots":[0,1,1],"control_points":[[1,0,0],[0,1,0]]}"#,
        )
        .unwrap();
        assert_eq!(doc.try_into_spline().unwrap_err().field, "knots");
    }

    #[test]
    fn points_input_errors_carry_pointers() {
        let e = |s: &str| PointsInput::from_json(&serde_json::from_str(s).unwrap()).unwrap_err();
        assert_eq!(e(r#"[[1,0,0],[0,"x",1]]"#).pointer, "/1/1");
        assert_eq!(e(r#"{"points":[[1,0,0],[0,2,0]]}"#).pointer, "/points/1");
        assert_eq!(
            e(r#"{"points":[[1,0,0]],"parameters":[null]}"#).pointer,
            "/parameters/0"
        );
        assert_eq!(e(r#"{"pts":[]}"#).pointer, "/pts");
        assert_eq!(e(r#"{"points":[[1,0,0],[1,0]]}"#).pointer, "/points/1");
        let ok = PointsInput::from_json(
            &serde_json::json!({"points": [[0, 0, 1], [0, 1, 0]], "parameters": [0, 5]}),
        )
        .unwrap();
        assert_eq!(ok.parameters, Some(vec![0.0, 5.0]));
    }

    #[test]
    fn spline_from_fit_output_points_into_spline() {
        let v = serde_json::json!({"spline": {"degree": 1, "knots": [0, 0, 1, 1], "control_points": [[1, 0, 0], [0, 0, 3]]}});
        assert_eq!(
            spline_from_json(&v).unwrap_err().pointer,
            "/spline/control_points/1"
        );
    }
}
