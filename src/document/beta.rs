//! The Beta-spline documents: a Beta-spline as JSON, the `interpolate` result, and reading any
//! curve document (B-spline or Beta-spline) with errors that carry a JSON pointer.

use crate::document::{number_list, number_rows, pointer, spline_from_json, InputError};
use crate::sphere::curve::beta::{expand_shape_parameters, SphericalBetaSpline};
use crate::sphere::curve::AnyCurve;
use crate::sphere::geometry::point::{angle, Dynamic, PointSet};
use crate::sphere::interpolate::beta::BetaInterpolation;
use crate::sphere::InputSite;
use serde::{Deserialize, Serialize};
use serde_json::Value;

/// In a Beta-spline document, the first control point of segment i must match the last of
/// segment i - 1 within this angle (radians): room for decimal printing of the same number by
/// another program, nothing more.
pub const JOINT_MATCH_RAD: f64 = 1e-12;

/// A Beta-spline as JSON: `{"type": "beta", "beta1": [...], "beta2": [...], "segments":
/// [[q0, q1, q2, q3], ...]}`, the cubic spherical Bézier control points (unit vectors) of each
/// segment; segment i spans parameter `[i, i + 1]`, and `q0` of segment i repeats `q3` of
/// segment i - 1. `beta1`/`beta2` hold one value per point (segments + 1); evaluation uses only
/// the segments, the shape parameters record how they were made.
///
/// Deserialising validates ([`BetaDocument::from_json`]); errors carry a JSON pointer such as
/// `/segments/2/1` or `/beta1/3`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "serde_json::Value")]
pub struct BetaDocument {
    /// Always `"beta"`.
    #[serde(rename = "type")]
    pub kind: String,
    /// `beta1` at every point.
    pub beta1: Vec<f64>,
    /// `beta2` at every point.
    pub beta2: Vec<f64>,
    /// Four control points per segment.
    pub segments: Vec<[Vec<f64>; 4]>,
}

impl From<&SphericalBetaSpline> for BetaDocument {
    fn from(s: &SphericalBetaSpline) -> Self {
        let segments = (0..s.segment_count())
            .map(|i| std::array::from_fn(|k| s.control_points().get(3 * i + k).to_vec()))
            .collect();
        BetaDocument {
            kind: "beta".to_string(),
            beta1: s.beta1().to_vec(),
            beta2: s.beta2().to_vec(),
            segments,
        }
    }
}

impl TryFrom<Value> for BetaDocument {
    type Error = InputError;
    fn try_from(v: Value) -> Result<Self, InputError> {
        BetaDocument::from_json(&v)
    }
}

impl BetaDocument {
    /// Parses and validates a Beta-spline document.
    ///
    /// # Errors
    /// An [`InputError`] whose pointer names the field and index at fault.
    pub fn from_json(v: &Value) -> Result<BetaDocument, InputError> {
        let doc = parse_document(v, "")?;
        doc.validate_at("")?;
        Ok(doc)
    }

    /// Validates the document and builds the curve.
    ///
    /// # Errors
    /// An [`InputError`] whose pointer (relative to the document) names the field and index.
    pub fn to_spline(&self) -> Result<SphericalBetaSpline, InputError> {
        self.validate_at("")
    }

    fn validate_at(&self, base: &str) -> Result<SphericalBetaSpline, InputError> {
        if self.kind != "beta" {
            return Err(InputError::at(
                format!("{base}/type"),
                format!("unknown curve type {:?} (expected \"beta\")", self.kind),
            ));
        }
        let n = self.segments.len();
        if n == 0 {
            return Err(InputError::at(
                format!("{base}/segments"),
                "a Beta-spline needs at least one segment",
            ));
        }
        let rows: Vec<&[f64]> = self
            .segments
            .iter()
            .flat_map(|s| s.iter().map(Vec::as_slice))
            .collect();
        let all = PointSet::try_from_rows(&rows).map_err(|e| {
            // Flat row index 4 s + k -> /segments/s/k.
            let pointer = match e.site() {
                InputSite::Point { index, coord } => pointer(
                    InputSite::Point {
                        index: index % 4,
                        coord,
                    },
                    "",
                    &format!("{base}/segments/{}", index / 4),
                ),
                _ => format!("{base}/segments"),
            };
            InputError::at(pointer, e.to_string())
        })?;
        let (dim, d) = (all.dim(), Dynamic(all.dim()));
        let mut control = Vec::with_capacity((3 * n + 1) * dim);
        for s in 0..n {
            if s > 0 {
                let gap = angle(d, all.get(4 * s), all.get(4 * s - 1));
                if gap.is_nan() || gap > JOINT_MATCH_RAD {
                    return Err(InputError::at(
                        format!("{base}/segments/{s}/0"),
                        format!(
                            "must equal the last control point of segment {} (the curve is continuous); they are {gap} rad apart",
                            s - 1
                        ),
                    ));
                }
            } else {
                control.extend_from_slice(all.get(0));
            }
            for k in 1..4 {
                control.extend_from_slice(all.get(4 * s + k));
            }
        }
        let control = PointSet::from_flat_unchecked(dim, control);
        if let Err(e) = control.check_no_antipodal_neighbours() {
            if let InputSite::Point { index, .. } = e.site() {
                let s = (index - 1) / 3;
                return Err(InputError::at(
                    format!("{base}/segments/{s}/{}", index - 3 * s),
                    e.to_string(),
                ));
            }
            return Err(InputError::at(format!("{base}/segments"), e.to_string()));
        }
        let (beta1, beta2) = match expand_shape_parameters(&self.beta1, &self.beta2, n + 1) {
            Ok(b) if self.beta1.len() == n + 1 && self.beta2.len() == n + 1 => b,
            Ok(_) => {
                let (field, got) = if self.beta1.len() != n + 1 {
                    ("beta1", self.beta1.len())
                } else {
                    ("beta2", self.beta2.len())
                };
                return Err(InputError::at(
                    format!("{base}/{field}"),
                    format!(
                        "expected {} values (one per point: segments + 1), got {got}",
                        n + 1
                    ),
                ));
            }
            Err(e) => return Err(InputError::at(pointer(e.site(), base, base), e.to_string())),
        };
        Ok(SphericalBetaSpline::from_parts(beta1, beta2, control))
    }
}

/// Reads the JSON shape of a Beta-spline document (types and counts, pointers from `base`).
fn parse_document(v: &Value, base: &str) -> Result<BetaDocument, InputError> {
    let map = v.as_object().ok_or_else(|| {
        InputError::at(
            base,
            "expected a Beta-spline document {\"type\": \"beta\", \"beta1\", \"beta2\", \"segments\"}",
        )
    })?;
    if let Some(k) = map
        .keys()
        .find(|k| !matches!(k.as_str(), "type" | "beta1" | "beta2" | "segments"))
    {
        return Err(InputError::at(
            format!("{base}/{k}"),
            "unknown field: a Beta-spline document has \"type\", \"beta1\", \"beta2\" and \"segments\"",
        ));
    }
    let kind = match map.get("type") {
        None => "beta".to_string(),
        Some(Value::String(s)) => s.clone(),
        Some(_) => {
            return Err(InputError::at(
                format!("{base}/type"),
                "expected the string \"beta\"",
            ))
        }
    };
    let field = |name: &str| {
        map.get(name).ok_or_else(|| {
            InputError::at(
                base,
                format!("missing field \"{name}\" of the Beta-spline document"),
            )
        })
    };
    let beta1 = number_list(field("beta1")?, &format!("{base}/beta1"))?;
    let beta2 = number_list(field("beta2")?, &format!("{base}/beta2"))?;
    let seg_base = format!("{base}/segments");
    let segs = field("segments")?
        .as_array()
        .ok_or_else(|| InputError::at(&seg_base, "expected an array of segments"))?;
    let mut segments = Vec::with_capacity(segs.len());
    for (i, s) in segs.iter().enumerate() {
        let rows = number_rows(s, &format!("{seg_base}/{i}"))?;
        let got = rows.len();
        let seg: [Vec<f64>; 4] = rows.try_into().map_err(|_| {
            InputError::at(
                format!("{seg_base}/{i}"),
                format!("expected 4 control points (a cubic segment), got {got}"),
            )
        })?;
        segments.push(seg);
    }
    Ok(BetaDocument {
        kind,
        beta1,
        beta2,
        segments,
    })
}

/// Reads a Beta-spline document, or an `interpolate` result holding one under `"curve"`.
///
/// # Errors
/// An [`InputError`] pointing at the offending value (e.g. `/curve/segments/1/2`).
pub fn beta_from_json(v: &Value) -> Result<SphericalBetaSpline, InputError> {
    let (doc_v, base) = match v.get("curve") {
        Some(c) => (c, "/curve"),
        None => (v, ""),
    };
    parse_document(doc_v, base)?.validate_at(base)
}

/// The result of `sphere interpolate` and `/v1/interpolate`: `{"curve": <Beta-spline
/// document>, "residual_rad": r, "iterations": k}`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct InterpolationDocument {
    /// The interpolating curve.
    pub curve: BetaDocument,
    /// Largest angle between the curve at parameter j and point j, radians.
    pub residual_rad: f64,
    /// Solver steps taken.
    pub iterations: usize,
}

impl From<&BetaInterpolation> for InterpolationDocument {
    fn from(r: &BetaInterpolation) -> Self {
        InterpolationDocument {
            curve: BetaDocument::from(&r.spline),
            residual_rad: r.residual_rad,
            iterations: r.iterations,
        }
    }
}

/// Reads any curve document: a spline document, a `sphere fit` result (`"spline"`), a
/// Beta-spline document, or a `sphere interpolate` result (`"curve"`). A document is a
/// Beta-spline when its `"type"` is `"beta"` or it has `"segments"`.
///
/// # Errors
/// An [`InputError`] pointing at the offending value.
pub fn curve_from_json(v: &Value) -> Result<AnyCurve, InputError> {
    let (inner, base) = if let Some(c) = v.get("curve") {
        (c, "/curve")
    } else if v.get("spline").is_some() {
        return spline_from_json(v).map(AnyCurve::BSpline);
    } else {
        (v, "")
    };
    let is_beta = inner.get("type").and_then(Value::as_str) == Some("beta")
        || inner.get("segments").is_some();
    if is_beta {
        return beta_from_json(v).map(AnyCurve::Beta);
    }
    spline_from_json(inner)
        .map(AnyCurve::BSpline)
        .map_err(|e| InputError::at(format!("{base}{}", e.pointer), e.message))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sphere::geometry::point::angle_between;
    use crate::sphere::interpolate::beta::{interpolate, InterpolationOptions};
    use crate::sphere::interpolate::paper_examples::{example1, example2};

    #[test]
    fn document_round_trips_and_names_bad_values() {
        let r = interpolate(&example1(), &InterpolationOptions::default()).unwrap();
        let doc = BetaDocument::from(&r.spline);
        let text = serde_json::to_string(&doc).unwrap();
        // serde_json's default float parser may be 1 ulp off, so compare geometrically.
        let back: BetaDocument = serde_json::from_str(&text).unwrap();
        let again = back.to_spline().unwrap();
        assert_eq!(again.beta1(), r.spline.beta1());
        assert_eq!(again.beta2(), r.spline.beta2());
        let (a, b) = (again.control_points(), r.spline.control_points());
        assert_eq!(a.len(), b.len());
        for i in 0..a.len() {
            assert!(angle_between(a.get(i), b.get(i)) < 1e-15);
        }

        let mut v: Value = serde_json::from_str(&text).unwrap();
        v["segments"][1][2] = serde_json::json!([0.0, 2.0, 0.0]);
        assert_eq!(
            BetaDocument::from_json(&v).unwrap_err().pointer,
            "/segments/1/2"
        );
        let mut v: Value = serde_json::from_str(&text).unwrap();
        v["segments"][2][0] = serde_json::json!([0.0, 1.0, 0.0]);
        assert_eq!(
            BetaDocument::from_json(&v).unwrap_err().pointer,
            "/segments/2/0"
        );
        let mut v: Value = serde_json::from_str(&text).unwrap();
        v["beta1"][3] = serde_json::json!(-1.0);
        assert_eq!(BetaDocument::from_json(&v).unwrap_err().pointer, "/beta1/3");
        let mut v: Value = serde_json::from_str(&text).unwrap();
        v["beta2"] = serde_json::json!([0.0]);
        assert_eq!(BetaDocument::from_json(&v).unwrap_err().pointer, "/beta2");
        let mut v: Value = serde_json::from_str(&text).unwrap();
        v["segments"][0] = serde_json::json!([[1, 0, 0], [0, 1, 0]]);
        assert_eq!(
            BetaDocument::from_json(&v).unwrap_err().pointer,
            "/segments/0"
        );
        let mut v: Value = serde_json::from_str(&text).unwrap();
        v["segments"][0][1][2] = serde_json::json!("x");
        assert_eq!(
            BetaDocument::from_json(&v).unwrap_err().pointer,
            "/segments/0/1/2"
        );
        let e = serde_json::from_value::<BetaDocument>(
            serde_json::json!({"type": "beta", "beta1": [1], "beta2": [0], "segments": []}),
        )
        .unwrap_err();
        assert!(e.to_string().contains("/segments"), "{e}");
    }

    #[test]
    fn curve_from_json_accepts_every_curve_document() {
        let r = interpolate(&example2(), &InterpolationOptions::default()).unwrap();
        let beta = serde_json::to_value(BetaDocument::from(&r.spline)).unwrap();
        let wrapped = serde_json::to_value(InterpolationDocument::from(&r)).unwrap();
        assert!(matches!(curve_from_json(&beta), Ok(AnyCurve::Beta(_))));
        assert!(matches!(curve_from_json(&wrapped), Ok(AnyCurve::Beta(_))));
        let spline = serde_json::json!({"degree": 1, "knots": [0, 0, 1, 1], "control_points": [[1, 0, 0], [0, 1, 0]]});
        assert!(matches!(curve_from_json(&spline), Ok(AnyCurve::BSpline(_))));
        let fit = serde_json::json!({ "spline": spline });
        assert!(matches!(curve_from_json(&fit), Ok(AnyCurve::BSpline(_))));
        let bad = serde_json::json!({"curve": {"degree": 1, "knots": [0, 0, 1, 1], "control_points": [[1, 0, 0], [0, 3, 0]]}});
        assert_eq!(
            curve_from_json(&bad).unwrap_err().pointer,
            "/curve/control_points/1"
        );
        let mut w = wrapped.clone();
        w["curve"]["segments"][0][3] = serde_json::json!([0, 0, 0]);
        assert_eq!(
            curve_from_json(&w).unwrap_err().pointer,
            "/curve/segments/0/3"
        );
    }
}
