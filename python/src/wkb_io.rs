//! WKB in and out: input geometries become the GeoJSON geometry values that
//! [`spherefit::earth::process_geometry`] takes (so the numbers are those of the CLI and the
//! service), and its output geometries become WKB again.
//!
//! Reading uses the georust `wkb` crate (zero-copy through `geo-traits`, both byte orders, ISO
//! and extended WKB with Z/M, and buffer lengths checked before any coordinate is read).
//! Writing is done here: that crate writes through `geo-traits` coordinate types, and the
//! usual implementations of those (`geo-types`) are 2-D, while fitted lines keep their
//! altitudes. The writer is ISO WKB, little-endian, 2-D or Z, for the four curve geometry
//! types the library outputs.

use geo_traits::{
    CoordTrait, GeometryTrait, LineStringTrait, MultiLineStringTrait, MultiPolygonTrait,
    PolygonTrait,
};
use serde_json::{json, Value};
use wkb::reader::read_wkb;

/// Why a WKB input cannot be fitted, with a JSON pointer into the GeoJSON form of the geometry
/// (`/coordinates/1/17/0`: part 1, position 17, longitude), as the library's errors have.
#[derive(Debug, Clone, PartialEq)]
pub struct WkbProblem {
    /// RFC 6901 pointer ("" for the geometry as a whole).
    pub pointer: String,
    /// What is wrong.
    pub message: String,
}

fn problem(pointer: impl Into<String>, message: impl Into<String>) -> WkbProblem {
    WkbProblem {
        pointer: pointer.into(),
        message: message.into(),
    }
}

/// What one input geometry is.
#[derive(Debug, Clone, PartialEq)]
pub enum Input {
    /// A LineString, MultiLineString, Polygon or MultiPolygon, as a GeoJSON geometry value.
    Curves(Value),
    /// A Point, MultiPoint or GeometryCollection: passes through unchanged, as in the CLI.
    PassThrough,
}

/// Parses one WKB geometry. Trailing bytes after the geometry, M values, and coordinates that
/// are not finite numbers are refused (never dropped); ranges and repeats are checked by the
/// library, as for GeoJSON.
pub fn read(buf: &[u8]) -> Result<Input, WkbProblem> {
    let g = read_wkb(buf).map_err(|e| problem("", format!("invalid WKB: {e}")))?;
    let used = g.buf().len();
    if used != buf.len() {
        return Err(problem(
            "",
            format!(
                "invalid WKB: {} bytes after the end of the geometry (byte {used} of {})",
                buf.len() - used,
                buf.len()
            ),
        ));
    }
    let dims = match g.dim() {
        geo_traits::Dimensions::Xy => 2,
        geo_traits::Dimensions::Xyz => 3,
        other => {
            return Err(problem(
                "",
                format!(
                    "{other:?} coordinates: only XY (lon, lat) and XYZ (lon, lat, altitude) are \
                     supported; M values would be lost"
                ),
            ))
        }
    };
    use geo_traits::GeometryType as G;
    let value = match g.as_type() {
        G::LineString(ls) => {
            json!({"type": "LineString", "coordinates": line(&ls, dims, "/coordinates")?})
        }
        G::MultiLineString(ml) => {
            let parts = ml
                .line_strings()
                .enumerate()
                .map(|(i, ls)| line(&ls, dims, &format!("/coordinates/{i}")))
                .collect::<Result<Vec<_>, _>>()?;
            json!({"type": "MultiLineString", "coordinates": parts})
        }
        G::Polygon(p) => {
            json!({"type": "Polygon", "coordinates": rings(&p, dims, "/coordinates")?})
        }
        G::MultiPolygon(mp) => {
            let polys = mp
                .polygons()
                .enumerate()
                .map(|(i, p)| rings(&p, dims, &format!("/coordinates/{i}")))
                .collect::<Result<Vec<_>, _>>()?;
            json!({"type": "MultiPolygon", "coordinates": polys})
        }
        _ => return Ok(Input::PassThrough),
    };
    Ok(Input::Curves(value))
}

/// The rings of a polygon (exterior first), as GeoJSON positions.
fn rings(
    p: &impl PolygonTrait<T = f64>,
    dims: usize,
    base: &str,
) -> Result<Vec<Value>, WkbProblem> {
    let mut out = Vec::with_capacity(1 + p.num_interiors());
    if let Some(ext) = p.exterior() {
        out.push(line(&ext, dims, &format!("{base}/0"))?);
    }
    for (i, r) in p.interiors().enumerate() {
        out.push(line(&r, dims, &format!("{base}/{}", i + 1))?);
    }
    Ok(out)
}

/// One line's positions, each coordinate checked to be a finite number.
fn line(ls: &impl LineStringTrait<T = f64>, dims: usize, base: &str) -> Result<Value, WkbProblem> {
    let mut out = Vec::with_capacity(ls.num_coords());
    for (i, c) in ls.coords().enumerate() {
        let mut pos = Vec::with_capacity(dims);
        for k in 0..dims {
            let x = c.nth_or_panic(k);
            let n = serde_json::Number::from_f64(x).ok_or_else(|| {
                problem(
                    format!("{base}/{i}/{k}"),
                    format!("{x} is not a finite number"),
                )
            })?;
            pos.push(Value::Number(n));
        }
        out.push(Value::Array(pos));
    }
    Ok(Value::Array(out))
}

/// Writes an output geometry of the library (LineString, MultiLineString, Polygon or
/// MultiPolygon, or the MultiPoint of an evaluation at times, with `[lon, lat]` or `[lon, lat, alt]` positions) as ISO WKB, little-endian.
///
/// # Errors
/// A message when the value is not such a geometry (a bug in the caller, reported, not a panic).
pub fn write(geometry: &Value) -> Result<Vec<u8>, String> {
    let kind = geometry
        .get("type")
        .and_then(Value::as_str)
        .ok_or("output geometry without a type")?;
    let coords = geometry
        .get("coordinates")
        .ok_or("output geometry without coordinates")?;
    let dims = first_position_len(coords).unwrap_or(2);
    if dims != 2 && dims != 3 {
        return Err(format!("output positions of {dims} numbers"));
    }
    let mut out = Vec::new();
    let code = match kind {
        "MultiPoint" => 4,
        "LineString" => 2,
        "Polygon" => 3,
        "MultiLineString" => 5,
        "MultiPolygon" => 6,
        other => return Err(format!("output geometry type {other}")),
    };
    write_node(&mut out, code, coords, dims)?;
    Ok(out)
}

fn header(out: &mut Vec<u8>, code: u32, dims: usize) {
    out.push(1); // little-endian
    let z = if dims == 3 { 1000 } else { 0 };
    out.extend_from_slice(&(code + z).to_le_bytes());
}

fn array(v: &Value) -> Result<&Vec<Value>, String> {
    v.as_array()
        .ok_or_else(|| "output coordinates are not arrays".to_string())
}

fn count(out: &mut Vec<u8>, n: usize) -> Result<(), String> {
    let n = u32::try_from(n).map_err(|_| format!("{n} items are more than WKB can count"))?;
    out.extend_from_slice(&n.to_le_bytes());
    Ok(())
}

/// A geometry of WKB type `code` (1 to 6) with its GeoJSON coordinates.
fn write_node(out: &mut Vec<u8>, code: u32, coords: &Value, dims: usize) -> Result<(), String> {
    header(out, code, dims);
    match code {
        1 => position(out, coords, dims),
        4 => {
            let points = array(coords)?;
            count(out, points.len())?;
            points.iter().try_for_each(|p| write_node(out, 1, p, dims))
        }
        2 => positions(out, coords, dims),
        3 => {
            let rings = array(coords)?;
            count(out, rings.len())?;
            rings.iter().try_for_each(|r| positions(out, r, dims))
        }
        5 | 6 => {
            let parts = array(coords)?;
            count(out, parts.len())?;
            let inner = if code == 5 { 2 } else { 3 };
            parts
                .iter()
                .try_for_each(|p| write_node(out, inner, p, dims))
        }
        _ => Err(format!("WKB type {code}")),
    }
}

fn positions(out: &mut Vec<u8>, coords: &Value, dims: usize) -> Result<(), String> {
    let ps = array(coords)?;
    count(out, ps.len())?;
    ps.iter().try_for_each(|p| position(out, p, dims))
}

/// One position's `dims` numbers.
fn position(out: &mut Vec<u8>, p: &Value, dims: usize) -> Result<(), String> {
    let p = array(p)?;
    if p.len() != dims {
        return Err("output positions of mixed dimensions".into());
    }
    for x in p {
        let x = x
            .as_f64()
            .ok_or("an output coordinate that is not a number")?;
        out.extend_from_slice(&x.to_le_bytes());
    }
    Ok(())
}

/// The length of the first position in nested coordinate arrays.
fn first_position_len(v: &Value) -> Option<usize> {
    let a = v.as_array()?;
    let first = a.first()?;
    if first.is_number() {
        Some(a.len())
    } else {
        a.iter().find_map(first_position_len)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn wkb_line(points: &[[f64; 2]]) -> Vec<u8> {
        let mut b = vec![1u8];
        b.extend_from_slice(&2u32.to_le_bytes());
        b.extend_from_slice(&(points.len() as u32).to_le_bytes());
        for p in points {
            b.extend_from_slice(&p[0].to_le_bytes());
            b.extend_from_slice(&p[1].to_le_bytes());
        }
        b
    }

    #[test]
    fn reads_a_line_as_geojson() {
        let b = wkb_line(&[[1.0, 2.0], [3.0, 4.5]]);
        assert_eq!(
            read(&b).unwrap(),
            Input::Curves(json!({"type": "LineString", "coordinates": [[1.0, 2.0], [3.0, 4.5]]}))
        );
    }

    #[test]
    fn round_trips_every_curve_type_in_2d_and_3d() {
        let geoms = [
            json!({"type": "LineString", "coordinates": [[1.0, 2.0], [3.0, 4.5]]}),
            json!({"type": "LineString", "coordinates": [[1.0, 2.0, 7.0], [3.0, 4.5, 8.0]]}),
            json!({"type": "MultiLineString", "coordinates": [[[1.0, 2.0], [3.0, 4.0]], [[5.0, 6.0], [7.0, 8.0]]]}),
            json!({"type": "Polygon", "coordinates": [[[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 0.0]], [[0.2, 0.2], [0.3, 0.2], [0.3, 0.3], [0.2, 0.2]]]}),
            json!({"type": "MultiPolygon", "coordinates": [[[[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [1.0, 1.0, 1.0], [0.0, 0.0, 1.0]]], [[[5.0, 5.0, 2.0], [6.0, 5.0, 2.0], [6.0, 6.0, 2.0], [5.0, 5.0, 2.0]]]]}),
        ];
        for g in geoms {
            let b = write(&g).unwrap();
            assert_eq!(read(&b).unwrap(), Input::Curves(g.clone()), "{g}");
        }
    }

    #[test]
    fn big_endian_and_passthrough() {
        let mut b = vec![0u8];
        b.extend_from_slice(&1u32.to_be_bytes());
        b.extend_from_slice(&1.5f64.to_be_bytes());
        b.extend_from_slice(&2.5f64.to_be_bytes());
        assert_eq!(read(&b).unwrap(), Input::PassThrough);
    }

    #[test]
    fn refuses_truncated_trailing_nonfinite_and_m() {
        let b = wkb_line(&[[1.0, 2.0], [3.0, 4.5]]);
        let e = read(&b[..b.len() - 3]).unwrap_err();
        assert!(e.message.starts_with("invalid WKB"), "{e:?}");
        let mut t = b.clone();
        t.push(0);
        let e = read(&t).unwrap_err();
        assert!(e.message.contains("1 bytes after the end"), "{e:?}");
        let n = wkb_line(&[[1.0, 2.0], [3.0, f64::NAN]]);
        let e = read(&n).unwrap_err();
        assert_eq!(e.pointer, "/coordinates/1/1");
        assert!(e.message.contains("not a finite number"));
        // ISO LineString M (2002).
        let mut m = vec![1u8];
        m.extend_from_slice(&2002u32.to_le_bytes());
        m.extend_from_slice(&1u32.to_le_bytes());
        for x in [1.0f64, 2.0, 3.0] {
            m.extend_from_slice(&x.to_le_bytes());
        }
        let e = read(&m).unwrap_err();
        assert!(e.message.contains("M values"), "{e:?}");
        assert!(read(&[]).is_err());
        assert!(read(&[7, 1, 2]).is_err());
    }
}
