//! The curves of a geometry (lines, rings, rings rejoined across ±180) fitted or interpolated,
//! with the area they bound before and after.

use crate::earth::curve::positions::json_kind;
use crate::earth::error::{EarthError, Problem};
use crate::earth::features::checks::check_other_geometry;
use crate::earth::features::run::run_curves;
use crate::earth::features::tighten::{ring_units, tighten_crossing_rings};
use crate::earth::features::times::{feature_times, line_times, FeatureTimes};
use crate::earth::features::{
    assemble, check_bbox, invalid, CurveJob, Made, CURVE_TYPES, OTHER_TYPES,
};
use crate::earth::job::Job;
use crate::earth::json_out::JsonOut;
use crate::earth::polygon::antimeridian::rejoin::rejoin_cut_polygons;
use crate::earth::polygon::area;

use serde_json::{json, Map, Value};

pub(in crate::earth) fn array_at<'a>(
    v: &'a Value,
    pointer: &str,
    what: &str,
) -> Result<&'a Vec<Value>, EarthError> {
    v.as_array().ok_or_else(|| {
        invalid(
            pointer,
            format!("expected an array of {what}, got {}", json_kind(v)),
        )
    })
}

/// Fits or interpolates the curves of a geometry; `None` for geometries that pass through.
pub(super) fn curves_of_geometry(
    geometry: &Value,
    ptr: &str,
    job: &Job,
    (feature, feature_pointer): (&Map<String, Value>, &str),
) -> Result<Made, EarthError> {
    if geometry.is_null() {
        return Ok(None);
    }
    let gmap = geometry.as_object().ok_or_else(|| {
        invalid(
            ptr,
            format!(
                "a geometry must be an object or null, got {}",
                json_kind(geometry)
            ),
        )
    })?;
    let kind = match gmap.get("type") {
        Some(Value::String(s)) => s.as_str(),
        _ => {
            return Err(invalid(
                format!("{ptr}/type"),
                "a geometry needs a string \"type\"",
            ))
        }
    };
    check_bbox(gmap, ptr)?;
    if OTHER_TYPES.contains(&kind) {
        check_other_geometry(gmap, kind, ptr, 0)?;
        return Ok(None);
    }
    if !CURVE_TYPES.contains(&kind) {
        return Err(invalid(
            format!("{ptr}/type"),
            format!("unknown geometry type {kind:?}"),
        ));
    }
    let cptr = format!("{ptr}/coordinates");
    let coords = gmap
        .get("coordinates")
        .ok_or_else(|| invalid(ptr, format!("a {kind} needs \"coordinates\"")))?;
    // Only a feature with lines needs times: others pass through whatever their properties.
    let times = &feature_times(feature, feature_pointer, job)?;
    if !matches!(times, FeatureTimes::None) && kind.ends_with("Polygon") {
        return Err(EarthError::new(
            format!("{ptr}/type"),
            Problem::InvalidTime(format!(
                "a fit in time (parameterization time) is for tracks (LineString, MultiLineString); a {kind}'s rings have no time order"
            )),
        ));
    }
    let mut jobs = Vec::new();
    let mk = |value, pointer, path, closed, times| CurveJob {
        value,
        pointer,
        path,
        closed,
        known_error_m: None,
        times,
        time_doc: None,
    };
    match kind {
        "LineString" => jobs.push(mk(
            coords,
            cptr.clone(),
            vec![],
            false,
            line_times(times, None)?,
        )),
        "MultiLineString" | "Polygon" => {
            let closed = kind == "Polygon";
            let what = if closed { "rings" } else { "lines" };
            for (i, part) in array_at(coords, &cptr, what)?.iter().enumerate() {
                jobs.push(mk(
                    part,
                    format!("{cptr}/{i}"),
                    vec![i],
                    closed,
                    line_times(times, Some(i))?,
                ));
            }
        }
        _ => {
            for (i, poly) in array_at(coords, &cptr, "polygons")?.iter().enumerate() {
                let pptr = format!("{cptr}/{i}");
                for (r, ring) in array_at(poly, &pptr, "rings")?.iter().enumerate() {
                    jobs.push(mk(ring, format!("{pptr}/{r}"), vec![i, r], true, None));
                }
            }
        }
    }
    // Polygons cut at ±180 (parts on either side, polar caps closed along the meridian and
    // the pole) are fitted as the rings on the sphere they are.
    let rejoined = match kind {
        "Polygon" => rejoin_cut_polygons(&[(cptr.clone(), coords)]),
        "MultiPolygon" => coords.as_array().and_then(|polys| {
            let polys: Vec<(String, &Value)> = polys
                .iter()
                .enumerate()
                .map(|(i, p)| (format!("{cptr}/{i}"), p))
                .collect();
            rejoin_cut_polygons(&polys)
        }),
        _ => None,
    };
    let rejoined = rejoined.transpose().map_err(no_area_on_the_sphere)?;
    let kind = match &rejoined {
        Some(polys) if kind == "Polygon" && polys.len() == 1 => "Polygon",
        Some(_) => "MultiPolygon",
        None => kind,
    };
    if let Some(polys) = &rejoined {
        jobs.clear();
        for (i, poly) in polys.iter().enumerate() {
            for (r, (pointer, ring)) in poly.rings.iter().enumerate() {
                let path = if kind == "Polygon" {
                    vec![r]
                } else {
                    vec![i, r]
                };
                jobs.push(mk(ring, pointer.clone(), path, true, None));
            }
        }
    }
    if jobs.is_empty() {
        return Ok(None);
    }
    let mut outputs = run_curves(&jobs, job)?;
    if kind.ends_with("Polygon") {
        tighten_crossing_rings(&jobs, &mut outputs, job)?;
    }
    // The fitted polylines were kept for those refits only.
    for o in outputs.iter_mut() {
        o.kept = None;
    }
    // Spherical area before and after, as shared fitting reports it: the input rings as read
    // (rejoined where they came cut) against the fitted rings before they are cut at ±180.
    let areas = kind.ends_with("Polygon").then(|| {
        let by_polygon = |path: &[usize]| if kind == "Polygon" { 0 } else { path[0] };
        let mut before: Vec<(usize, Vec<Vec<[f64; 3]>>)> = Vec::new();
        for j in &jobs {
            let key = by_polygon(&j.path);
            match before.last_mut() {
                Some((k, rings)) if *k == key => rings.push(ring_units(j.value)),
                _ => before.push((key, vec![ring_units(j.value)])),
            }
        }
        let mut after: Vec<(usize, Vec<&[[f64; 3]]>)> = Vec::new();
        for c in &outputs {
            let key = by_polygon(&c.report.path);
            match after.last_mut() {
                Some((k, rings)) if *k == key => rings.push(&c.points),
                _ => after.push((key, vec![&c.points[..]])),
            }
        }
        let sum_before: f64 = before.iter().map(|(_, r)| area::polygon_area_m2(r)).sum();
        let sum_after: f64 = after.iter().map(|(_, r)| area::polygon_area_m2(r)).sum();
        (sum_after, area::area_change(sum_before, sum_after))
    });
    // The pole each rejoined polygon was closed along in the input, kept in the output.
    let poles: Vec<Option<f64>> = rejoined.iter().flatten().map(|p| p.pole).collect();
    let (mut geometry_out, mut info, stats, extra) = assemble(kind, outputs, &poles, job)?;
    if let (Some((area_m2, change)), JsonOut::Object(m)) = (areas, &mut info) {
        m.insert(
            "area_m2".into(),
            JsonOut::Value(json!(crate::earth::lonlat::round_to(area_m2, 0))),
        );
        m.insert(
            "area_change".into(),
            JsonOut::Value(json!(crate::earth::lonlat::round_to(change, 9))),
        );
    }
    // Foreign members of the geometry object come back with it (RFC 7946 §6.1).
    if let JsonOut::Object(m) = &mut geometry_out {
        for (k, v) in gmap {
            if !matches!(k.as_str(), "type" | "coordinates" | "bbox") {
                m.insert(k.clone(), JsonOut::Value(v.clone()));
            }
        }
    }
    Ok(Some((geometry_out, info, stats, extra)))
}

/// The error for a ring that [`rejoin_cut_polygons`] found to bound no area on the sphere.
pub(in crate::earth) fn no_area_on_the_sphere(pointer: String) -> EarthError {
    EarthError::new(
        pointer,
        Problem::InvalidRing(
            "on the sphere this ring has fewer than 3 distinct positions and bounds no area: \
             its edges along -180 and 180 (one meridian) and the poles meet themselves. A \
             latitude band or the whole world drawn in the lon/lat plane needs vertices along \
             its parallels"
                .into(),
        ),
    )
}
