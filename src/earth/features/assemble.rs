//! The output of one feature: its geometry (cut at ±180), `properties.fit` (or
//! `interpolation`, `evaluation`) and its counters, from the curves made.

use crate::earth::curve::output::{
    compression_ratio, output_position, output_positions, CurveOutput, CurveReport,
};
use crate::earth::curve::stored::{lonlat_of_positions, CONTROL_POINTS_OF_GEOMETRY};
use crate::earth::error::{EarthError, Problem};
use crate::earth::features::{Assembled, FeatureStats};
use crate::earth::job::{Job, Operation};
use crate::earth::json_out::JsonOut;
use crate::earth::polygon::antimeridian::cut_line;
use crate::earth::polygon::antimeridian::split::split_polygon_around;
use crate::earth::polygon::small_rings;
use crate::earth::time::TimeOrigin;

use serde_json::{json, Map, Value};

/// A geometry object of `kind` with these coordinates.
pub(super) fn geometry(kind: &str, coordinates: JsonOut) -> JsonOut {
    JsonOut::object([
        ("type", JsonOut::Value(Value::from(kind))),
        ("coordinates", coordinates),
    ])
}

/// Builds the output geometry, the properties object and the stats from fitted curves.
/// `poles[i]`: the pole polygon `i` is closed along if it goes round one (cut-form input,
/// [`crate::earth::polygon::antimeridian::rejoin::RejoinedPolygon::pole`]); empty when none is known.
pub(super) fn assemble(
    kind: &str,
    mut outputs: Vec<CurveOutput>,
    poles: &[Option<f64>],
    job: &Job,
) -> Result<Assembled, EarthError> {
    let precision = job.output.precision;
    // drop_small_rings: the rings kept as small are dropped (small_rings::drop_kept); they
    // still count as curves read.
    let (dropped, dropped_curves, dropped_input) =
        if job.drop_small_rings && kind.ends_with("Polygon") {
            let input: usize = outputs.iter().map(|c| c.report.input_points).sum();
            let n = outputs.len();
            let dropped = small_rings::drop_kept(&mut outputs);
            let left: usize = outputs.iter().map(|c| c.report.input_points).sum();
            (Some(dropped), n - outputs.len(), input - left)
        } else {
            (None, 0, 0)
        };
    // A curve whose knots or parameters under- or overflow samples to non-finite points; that
    // is the input's fault and is said so (never `null` coordinates or an empty geometry).
    for c in &outputs {
        if let Some(i) = c
            .points
            .iter()
            .position(|p| p.iter().any(|x| !x.is_finite()))
        {
            return Err(EarthError::new(
                c.pointer.clone(),
                Problem::Fit(crate::sphere::SphereError::NonFinite {
                    what: "the sampled curve",
                    why: format!("output point {i} is not a number: the knot spans or parameters under- or overflow in floating point; rescale them"),
                }),
            ));
        }
    }
    // Times of the dense output kept in a property: one array per output line.
    let mut time_pieces: Vec<Value> = Vec::new();
    let mut time_name: Option<String> = None;
    // Whether the output is a single LineString (its times are then one array, not nested).
    let mut is_line_string = false;
    let geometry = match kind {
        "LineString" | "MultiLineString" => {
            let mut pieces = Vec::new();
            for c in &outputs {
                let cut = cut_line(&c.points, &c.alts);
                let Some(t) = &c.time else {
                    for piece in cut {
                        pieces.push(output_positions(&piece, c.has_alt, precision));
                    }
                    continue;
                };
                // The same cut with the times in the place of the altitudes: the same pieces,
                // with the times interpolated where a piece meets the antimeridian.
                let cut_t = cut_line(&c.points, &t.unix_s);
                for (piece, tp) in cut.iter().zip(&cut_t) {
                    match &t.origin {
                        TimeOrigin::M => pieces.push(JsonOut::Value(Value::Array(
                            piece
                                .iter()
                                .zip(tp)
                                .map(|(p, q)| {
                                    let mut v = output_position(p, true, precision);
                                    if let Value::Array(a) = &mut v {
                                        a.push(t.format.write(q[2]));
                                    }
                                    v
                                })
                                .collect(),
                        ))),
                        TimeOrigin::Property(name) => {
                            pieces.push(output_positions(piece, c.has_alt, precision));
                            time_name = Some(name.clone());
                            time_pieces.push(Value::Array(
                                tp.iter().map(|q| t.format.write(q[2])).collect(),
                            ));
                        }
                    }
                }
            }
            if kind == "LineString" && pieces.len() == 1 {
                is_line_string = true;
                geometry("LineString", pieces.pop().expect("one piece"))
            } else {
                geometry("MultiLineString", JsonOut::Array(pieces))
            }
        }
        _ => {
            // Group rings by polygon (path [ring] for a Polygon, [polygon, ring] otherwise).
            let mut polygons: Vec<(usize, Vec<&CurveOutput>)> = Vec::new();
            for c in &outputs {
                let key = if kind == "Polygon" {
                    0
                } else {
                    c.report.path[0]
                };
                match polygons.last_mut() {
                    Some((k, rings)) if *k == key => rings.push(c),
                    _ => polygons.push((key, vec![c])),
                }
            }
            let mut pieces = Vec::new();
            for (key, rings) in &polygons {
                let has_alt = rings.iter().all(|r| r.has_alt);
                // A ring kept whole because it is too small to fit can be smaller than the
                // grid a tolerance chose (a sliver 1e-4 degrees wide at 3 decimals): its
                // polygon is written at the default precision at least, so it keeps its
                // positions apart.
                let precision = if rings
                    .iter()
                    .any(|r| r.report.fields.contains_key("small_ring"))
                {
                    precision.max(crate::earth::DEFAULT_PRECISION)
                } else {
                    precision
                };
                let lonlat_rings: Vec<Vec<[f64; 3]>> = rings
                    .iter()
                    .map(|r| {
                        r.points
                            .iter()
                            .zip(&r.alts)
                            .map(|(p, &alt)| {
                                let (lon, lat) = crate::earth::lonlat::unit_to_lonlat(p);
                                [lon, lat, alt]
                            })
                            .collect()
                    })
                    .collect();
                // Output positions are rounded when written; the pieces need no rounding here.
                let pole = poles.get(*key).copied().flatten();
                let split = split_polygon_around(&lonlat_rings, &|x| x, pole);
                for poly in split {
                    pieces.push(JsonOut::Array(
                        poly.iter()
                            .map(|ring| output_positions(ring, has_alt, precision))
                            .collect(),
                    ));
                }
            }
            if kind == "Polygon" && pieces.len() == 1 {
                geometry("Polygon", pieces.pop().expect("one piece"))
            } else {
                geometry("MultiPolygon", JsonOut::Array(pieces))
            }
        }
    };
    let mut stats = FeatureStats::default();
    for c in &outputs {
        stats.curves += 1;
        stats.input_points += c.report.input_points;
        stats.output_points += c.report.output_points;
        stats.stored_numbers += c.report.stored_numbers;
        stats.max_error_m = stats.max_error_m.max(c.report.max_error_m);
    }
    stats.curves += dropped_curves;
    stats.input_points += dropped_input;
    // Rings kept whole because they were too small to fit (small_rings), by pointer, as
    // shared fitting lists them.
    let kept: Vec<String> = outputs
        .iter()
        .filter(|c| c.report.fields.contains_key("small_ring"))
        .map(|c| c.pointer.clone())
        .collect();
    if job.output.splines_refer_to_geometry {
        for c in &mut outputs {
            refer_to_geometry(&mut c.report, &geometry, kind);
        }
    }
    let mut info = properties_object(kind, outputs.into_iter().map(|c| c.report).collect(), job);
    if kind.ends_with("Polygon") {
        if let JsonOut::Object(m) = &mut info {
            m.insert("kept_rings".into(), JsonOut::Value(json!(kept)));
            if let Some(d) = &dropped {
                m.insert("dropped_rings".into(), JsonOut::Value(json!(d)));
            }
        }
    }
    let mut extra = Vec::new();
    if let Some(name) = time_name {
        let value = if is_line_string && time_pieces.len() == 1 {
            time_pieces.pop().expect("one piece")
        } else {
            Value::Array(time_pieces)
        };
        extra.push((name, value));
    }
    Ok((geometry, info, stats, extra))
}

/// A degree-1 spline whose control points are exactly the positions written in `geometry` at
/// its part's path is made to refer to them ([`CONTROL_POINTS_OF_GEOMETRY`]), without its knots
/// when they are the clamped uniform ones: the curve is then written once. Any other spline
/// (a compact curve, another degree, a line cut at ±180 whose positions moved) is kept.
pub(super) fn refer_to_geometry(report: &mut CurveReport, geometry: &JsonOut, kind: &str) {
    let Some(JsonOut::Object(spline)) = &mut report.spline else {
        return;
    };
    if !matches!(spline.get("degree"), Some(JsonOut::Value(d)) if d.as_u64() == Some(1)) {
        return;
    }
    let Some(JsonOut::Rows {
        numbers: ctrl,
        width: 2,
    }) = spline.get("control_points")
    else {
        return;
    };
    let JsonOut::Object(g) = geometry else {
        return;
    };
    if !matches!(g.get("type"), Some(JsonOut::Value(t)) if t.as_str() == Some(kind)) {
        return;
    }
    let mut at = g.get("coordinates");
    for &i in &report.path {
        at = match at {
            Some(JsonOut::Array(a)) => a.get(i),
            _ => None,
        };
    }
    let same = match at {
        Some(JsonOut::Rows { numbers, width }) if *width >= 2 => {
            numbers.len() / width == ctrl.len() / 2
                && numbers
                    .chunks(*width)
                    .zip(ctrl.chunks(2))
                    .all(|(p, c)| p[..2] == *c)
        }
        Some(JsonOut::Value(v)) => {
            lonlat_of_positions(v).is_some_and(|ll| ll.iter().flatten().eq(ctrl.iter()))
        }
        _ => false,
    };
    if !same {
        return;
    }
    let n = ctrl.len() / 2;
    spline.insert(
        "control_points".into(),
        JsonOut::Value(json!(CONTROL_POINTS_OF_GEOMETRY)),
    );
    let uniform = crate::sphere::curve::bspline::clamped_uniform_knots(n, 1);
    if matches!(spline.get("knots"), Some(JsonOut::Numbers(k)) if *k == uniform) {
        spline.remove("knots");
    }
}

/// `properties.fit` (or `interpolation`, `evaluation`): a LineString's fields directly; for
/// other geometries, totals over the parts plus `geometry` and `parts`.
pub(super) fn properties_object(kind: &str, mut reports: Vec<CurveReport>, job: &Job) -> JsonOut {
    if kind == "LineString" && reports.len() == 1 {
        return JsonOut::Object(reports.pop().expect("one report").into_members());
    }
    let mut out = Map::new();
    let n_in: usize = reports.iter().map(|r| r.input_points).sum();
    let sum = |f: &dyn Fn(&CurveReport) -> usize| reports.iter().map(f).sum::<usize>();
    let round_m = |x: f64| crate::earth::lonlat::round_to(x, 3);
    if !matches!(job.operation, Operation::Evaluate) {
        let max = reports.iter().map(|r| r.max_error_m).fold(0.0, f64::max);
        out.insert("max_error_m".into(), json!(round_m(max)));
        if job.operation.fit_options().is_some() {
            let s: f64 = reports.iter().map(|r| r.error_sum_m).sum();
            let sq: f64 = reports.iter().map(|r| r.error_sq_sum_m2).sum();
            let n = n_in.max(1) as f64;
            out.insert("mean_error_m".into(), json!(round_m(s / n)));
            out.insert("rms_error_m".into(), json!(round_m((sq / n).sqrt())));
        }
        out.insert("input_points".into(), json!(n_in));
    }
    if let Operation::FitToTolerance { tolerance_m, .. } = &job.operation {
        let met = reports
            .iter()
            .all(|r| r.fields.get("tolerance_met") == Some(&Value::Bool(true)));
        let stored = sum(&|r: &CurveReport| r.stored_numbers);
        out.insert("tolerance_m".into(), json!(tolerance_m));
        out.insert("tolerance_met".into(), json!(met));
        // The feature's bound: the worst of its parts' (each certified).
        let two_way = reports
            .iter()
            .filter_map(|r| r.fields.get("two_way_distance_m").and_then(Value::as_f64))
            .fold(0.0, f64::max);
        out.insert("two_way_distance_m".into(), json!(two_way));
        out.insert("stored_numbers".into(), json!(stored));
        out.insert(
            "compression_ratio".into(),
            json!(compression_ratio(n_in, stored)),
        );
    }
    if let Some(o) = job.operation.fit_options() {
        let ctrl: usize = reports
            .iter()
            .filter_map(|r| r.fields.get("control_points").and_then(Value::as_u64))
            .sum::<u64>() as usize;
        out.insert("control_points".into(), json!(ctrl));
        let iters = reports
            .iter()
            .filter_map(|r| r.fields.get("iterations").and_then(Value::as_u64))
            .max()
            .unwrap_or(0);
        out.insert("iterations".into(), json!(iters));
        let converged = reports
            .iter()
            .all(|r| r.fields.get("converged") == Some(&Value::Bool(true)));
        out.insert("converged".into(), json!(converged));
        if matches!(job.operation, Operation::Fit(_)) {
            out.insert(
                "knots".into(),
                serde_json::to_value(o.knots).expect("enum serialises"),
            );
        }
        out.insert(
            "parameterization".into(),
            if job.time.fit_in_time.is_some() {
                json!("time")
            } else {
                serde_json::to_value(o.parameterization).expect("enum serialises")
            },
        );
    }
    out.insert(
        "output_points".into(),
        json!(sum(&|r: &CurveReport| r.output_points)),
    );
    let dev = reports
        .iter()
        .filter_map(|r| r.fields.get("sampling_deviation_m").and_then(Value::as_f64))
        .fold(0.0, f64::max);
    out.insert("sampling_deviation_m".into(), json!(dev));
    out.insert("geometry".into(), json!(kind));
    let parts: Vec<JsonOut> = reports
        .into_iter()
        .map(|r| {
            let (path, closed) = (json!(r.path), json!(r.closed));
            let mut m = r.into_members();
            m.insert("path".into(), JsonOut::Value(path));
            m.insert("closed".into(), JsonOut::Value(closed));
            JsonOut::Object(m)
        })
        .collect();
    let mut out = JsonOut::from(out);
    if let JsonOut::Object(m) = &mut out {
        m.insert("parts".into(), JsonOut::Array(parts));
    }
    out
}
