//! Checks of what passes through unfitted (points, collections) and of `bbox` members, so the
//! output is valid GeoJSON.

use crate::earth::curve::positions::json_kind;
use crate::earth::error::{EarthError, Problem};
use crate::earth::features::{array_at, invalid, CURVE_TYPES, OTHER_TYPES};

use serde_json::{Map, Value};

/// Checks a `bbox` member, if any: an array of 2n numbers, n >= 2 (RFC 7946 §5).
pub(in crate::earth) fn check_bbox(map: &Map<String, Value>, ptr: &str) -> Result<(), EarthError> {
    let Some(b) = map.get("bbox") else {
        return Ok(());
    };
    let ok = b
        .as_array()
        .is_some_and(|a| (a.len() == 4 || a.len() == 6) && a.iter().all(Value::is_number));
    if ok {
        Ok(())
    } else {
        Err(invalid(
            format!("{ptr}/bbox"),
            "a bbox is an array of 4 or 6 numbers",
        ))
    }
}

/// Nesting limit for GeometryCollections (RFC 7946 discourages nesting them at all).
pub(super) const MAX_COLLECTION_DEPTH: usize = 32;

/// Checks a geometry that passes through unchanged (Point, MultiPoint, GeometryCollection):
/// the same position rules as for lines, so what comes out is valid GeoJSON.
pub(super) fn check_other_geometry(
    gmap: &Map<String, Value>,
    kind: &str,
    ptr: &str,
    depth: usize,
) -> Result<(), EarthError> {
    if kind == "GeometryCollection" {
        if depth >= MAX_COLLECTION_DEPTH {
            return Err(invalid(ptr, "GeometryCollections nested too deeply"));
        }
        let gptr = format!("{ptr}/geometries");
        let geoms = gmap
            .get("geometries")
            .ok_or_else(|| invalid(ptr, "a GeometryCollection needs \"geometries\""))?;
        for (i, g) in array_at(geoms, &gptr, "geometries")?.iter().enumerate() {
            let iptr = format!("{gptr}/{i}");
            let m = g.as_object().ok_or_else(|| {
                invalid(
                    &iptr,
                    format!("a geometry must be an object, got {}", json_kind(g)),
                )
            })?;
            let k = m.get("type").and_then(Value::as_str).unwrap_or("");
            check_bbox(m, &iptr)?;
            if OTHER_TYPES.contains(&k) {
                check_other_geometry(m, k, &iptr, depth + 1)?;
            } else if CURVE_TYPES.contains(&k) {
                let depth_of = match k {
                    "LineString" => 1,
                    "MultiLineString" | "Polygon" => 2,
                    _ => 3,
                };
                let c = m
                    .get("coordinates")
                    .ok_or_else(|| invalid(&iptr, format!("a {k} needs \"coordinates\"")))?;
                let rings = k.ends_with("Polygon");
                check_nested_positions(c, &format!("{iptr}/coordinates"), depth_of, rings)?;
            } else {
                return Err(invalid(
                    format!("{iptr}/type"),
                    format!("unknown geometry type {k:?}"),
                ));
            }
        }
        return Ok(());
    }
    let c = gmap
        .get("coordinates")
        .ok_or_else(|| invalid(ptr, format!("a {kind} needs \"coordinates\"")))?;
    let cptr = format!("{ptr}/coordinates");
    if kind == "Point" {
        check_position(c, &cptr)
    } else {
        for (i, p) in array_at(c, &cptr, "positions")?.iter().enumerate() {
            check_position(p, &format!("{cptr}/{i}"))?;
        }
        Ok(())
    }
}

/// Checks one position of a geometry that passes through: an array of at least two numbers,
/// longitude and latitude in range. Its other numbers (altitude, measures) are the user's and
/// come back as they are, whatever the other positions have.
pub(super) fn check_position(p: &Value, ptr: &str) -> Result<(), EarthError> {
    let nums = p.as_array().ok_or_else(|| {
        EarthError::new(
            ptr,
            Problem::InvalidCoordinate(format!(
                "a position is an array [longitude, latitude, ...], got {}",
                json_kind(p)
            )),
        )
    })?;
    if nums.len() < 2 {
        return Err(EarthError::new(
            ptr,
            Problem::InvalidCoordinate(format!(
                "a position has at least 2 numbers ([longitude, latitude, ...]), this one has {}",
                nums.len()
            )),
        ));
    }
    for (k, x) in nums.iter().enumerate().skip(2) {
        if !x.is_number() {
            return Err(EarthError::new(
                format!("{ptr}/{k}"),
                Problem::InvalidCoordinate(format!("expected a number, got {}", json_kind(x))),
            ));
        }
    }
    crate::earth::curve::positions::parse_positions(
        &Value::Array(vec![Value::Array(nums[..2].to_vec())]),
        "",
    )
    .map_err(|e| EarthError::new(format!("{ptr}{}", &e.pointer[2..]), e.problem))?;
    Ok(())
}

/// Checks arrays of positions nested `depth` deep (1: a line's positions, or a ring's when
/// `rings`): every position, at least 2 positions in a line, and rings closed with at least 4
/// (RFC 7946 §3.1.4, §3.1.6), as for the lines and rings that are fitted.
pub(super) fn check_nested_positions(
    v: &Value,
    ptr: &str,
    depth: usize,
    rings: bool,
) -> Result<(), EarthError> {
    if depth == 1 {
        let positions = array_at(v, ptr, "positions")?;
        for (i, p) in positions.iter().enumerate() {
            check_position(p, &format!("{ptr}/{i}"))?;
        }
        let n = positions.len();
        let lonlat = |p: &Value| [p[0].as_f64(), p[1].as_f64()];
        if rings && n < 4 {
            return Err(EarthError::new(
                ptr,
                Problem::InvalidRing(format!(
                    "a Polygon ring needs at least 4 positions (the last repeating the first), got {n}"
                )),
            ));
        }
        if rings && lonlat(&positions[0]) != lonlat(&positions[n - 1]) {
            return Err(EarthError::new(
                format!("{ptr}/{}", n - 1),
                Problem::InvalidRing(
                    "a Polygon ring must end where it starts: the last position differs from the first"
                        .into(),
                ),
            ));
        }
        if !rings && n < 2 {
            return Err(EarthError::new(
                ptr,
                Problem::TooFewPoints {
                    distinct: n,
                    need: 2,
                },
            ));
        }
        return Ok(());
    }
    for (i, x) in array_at(v, ptr, "arrays of positions")?.iter().enumerate() {
        check_nested_positions(x, &format!("{ptr}/{i}"), depth - 1, rings)?;
    }
    Ok(())
}
