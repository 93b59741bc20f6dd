//! Interpolating one line with a spherical Beta-spline ([`interpolate_line`]).

use crate::document::beta::BetaDocument;
use crate::earth::curve::line::{ErrorSums, LineRef, OutputSpec};
use crate::earth::curve::output::{
    finish_dense, ring_sampling, sampling_start, CurveOutput, CurveReport,
};
use crate::earth::curve::positions::{prepare_line, round_m, sphere_error};
use crate::earth::error::{EarthError, Problem};
use crate::earth::job::InterpolateSettings;
use crate::earth::lonlat::{lonlat_to_unit, m_to_rad, rad_to_m, round_to, unit_to_lonlat};
use crate::earth::sampling::{sample, AUTO_DEVIATION_FLOOR_M};
use crate::sphere::curve::beta::SphericalBetaSpline;
use crate::sphere::geometry::point::angle_between;
use crate::sphere::interpolate::beta::{interpolate, InterpolationOptions};
use crate::sphere::SphereError;
use serde_json::{json, Map, Value};

/// Automatic sampling of an interpolating curve keeps the polyline within this share of the
/// mean vertex spacing of the curve (and at least `AUTO_DEVIATION_FLOOR_M`): the curve has no
/// fit error to compare with, and 0.5 % of a step is far below what the vertices resolve.
pub const INTERPOLATION_DEVIATION_FRACTION: f64 = 0.005;

/// Interpolates every distinct position of one line (or ring) with a spherical Beta-spline.
///
/// # Errors
/// As [`fit_line`](crate::earth::curve::fitting::fit_line), plus [`Problem::Interpolation`] when the shape parameters cannot be met.
pub fn interpolate_line(
    src: LineRef<'_>,
    settings: &InterpolateSettings,
    out: OutputSpec<'_>,
) -> Result<CurveOutput, EarthError> {
    let (output, limits) = (out.output, out.limits);
    let (pointer, closed) = (src.pointer, src.closed);
    let (line, distinct, _) = prepare_line(src.value, pointer, closed, None)?;
    let points = distinct.point_set();
    let opts = InterpolationOptions::default()
        .with_beta1(settings.beta1)
        .with_beta2(settings.beta2);
    let fit_err = |e: SphereError| sphere_error(e, pointer, &distinct.input_index);
    let r = interpolate(&points, &opts).map_err(fit_err)?;
    let (curve, doc) = round_beta(&r.spline, output.precision)
        .map_err(|e| EarthError::new(pointer, Problem::RoundedCurve(e)))?;
    // Distance from each input position to the rounded curve at its parameter j.
    let params: Vec<f64> = (0..distinct.len()).map(|j| j as f64).collect();
    let at = curve.evaluate_many(&params);
    let errors = ErrorSums::of(at.iter().enumerate().map(|(j, c)| {
        (
            angle_between(&distinct.points[j], c),
            distinct.multiplicity[j],
        )
    }));
    let max_rad = errors.max_rad;
    let n_in = line.points.len();
    let segments = distinct.len() - 1;
    // No fit error to stay below here: automatic sampling keeps within a small share of the
    // mean vertex spacing instead.
    let mean_step_rad = distinct
        .points
        .windows(2)
        .map(|w| angle_between(&w[0], &w[1]))
        .sum::<f64>()
        / segments as f64;
    let dense = sample(
        &curve,
        ring_sampling(output.sampling, closed),
        (INTERPOLATION_DEVIATION_FRACTION * mean_step_rad).max(m_to_rad(AUTO_DEVIATION_FLOOR_M)),
        sampling_start(segments),
        limits.max_samples,
    )
    .map_err(|e| EarthError::new(pointer, e.problem))?;
    let (points_out, alts) = finish_dense(&dense, closed, &params, &distinct.alts);
    let mut fields = Map::new();
    fields.insert("max_error_m".into(), json!(round_m(rad_to_m(max_rad))));
    fields.insert("input_points".into(), json!(n_in));
    fields.insert("segments".into(), json!(segments));
    fields.insert("output_points".into(), json!(points_out.len()));
    fields.insert(
        "sampling_deviation_m".into(),
        json!(round_m(rad_to_m(dense.max_deviation_rad))),
    );
    fields.insert("curve".into(), doc);
    Ok(CurveOutput {
        pointer: pointer.to_string(),
        has_alt: line.alts.is_some(),
        report: CurveReport {
            output_points: points_out.len(),
            stored_numbers: curve.stored_numbers(),
            ..CurveReport::of_line(src, fields, n_in, errors)
        },
        points: points_out,
        alts,
        time: None,
        kept: None,
    })
}

/// A Beta-spline with control points rounded to `precision`, and its lon/lat document.
pub(super) fn round_beta(
    s: &SphericalBetaSpline,
    precision: u32,
) -> Result<(SphericalBetaSpline, Value), crate::document::InputError> {
    let doc = BetaDocument::from(s);
    let round_pt = |p: &Vec<f64>| {
        let (lon, lat) = unit_to_lonlat(p);
        [round_to(lon, precision), round_to(lat, precision)]
    };
    let ll_segments: Vec<Vec<[f64; 2]>> = doc
        .segments
        .iter()
        .map(|seg| seg.iter().map(round_pt).collect())
        .collect();
    let unit_doc = BetaDocument {
        kind: doc.kind.clone(),
        beta1: doc.beta1.clone(),
        beta2: doc.beta2.clone(),
        segments: ll_segments
            .iter()
            .map(|seg| std::array::from_fn(|k| lonlat_to_unit(seg[k][0], seg[k][1]).to_vec()))
            .collect(),
    };
    let spline = unit_doc.to_spline()?;
    let json_doc = json!({
        "type": "beta",
        "beta1": doc.beta1,
        "beta2": doc.beta2,
        "segments": ll_segments,
    });
    Ok((spline, json_doc))
}
