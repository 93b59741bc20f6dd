//! Well-known binary (ISO / OGC WKB, and the GeoPackage geometry blob around it) to and from
//! GeoJSON geometries.
//!
//! Read: Point, LineString, Polygon, Multi*, GeometryCollection, 2-D, Z, M and ZM (ISO codes
//! 1000+/2000+/3000+ and the EWKB high bits); Z is kept as the third number, M dropped. Every
//! length is checked against the bytes left before anything is allocated, so a corrupt blob is
//! an error naming its offset, never a panic or a huge allocation.

use crate::formats::{number, position};
use serde_json::{json, Value};

/// Geometry nesting deeper than this is refused (collections of collections...).
const MAX_DEPTH: usize = 32;

/// A WKB reader over `bytes`; `offset` is where an error was found.
struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

/// Why a blob could not be read, and at which byte of it.
#[derive(Debug)]
pub struct WkbError {
    pub offset: usize,
    pub reason: String,
}

type R<T> = Result<T, WkbError>;

impl<'a> Reader<'a> {
    fn fail<T>(&self, reason: impl Into<String>) -> R<T> {
        Err(WkbError {
            offset: self.at,
            reason: reason.into(),
        })
    }

    fn take(&mut self, n: usize) -> R<&'a [u8]> {
        if self.bytes.len() - self.at < n {
            return self.fail(format!(
                "the geometry is truncated: {n} more bytes needed, {} left",
                self.bytes.len() - self.at
            ));
        }
        let s = &self.bytes[self.at..self.at + n];
        self.at += n;
        Ok(s)
    }

    fn u8(&mut self) -> R<u8> {
        Ok(self.take(1)?[0])
    }

    fn u32(&mut self, little: bool) -> R<u32> {
        let b: [u8; 4] = self.take(4)?.try_into().unwrap_or([0; 4]);
        Ok(if little {
            u32::from_le_bytes(b)
        } else {
            u32::from_be_bytes(b)
        })
    }

    fn f64(&mut self, little: bool) -> R<f64> {
        let b: [u8; 8] = self.take(8)?.try_into().unwrap_or([0; 8]);
        Ok(if little {
            f64::from_le_bytes(b)
        } else {
            f64::from_be_bytes(b)
        })
    }

    /// A count of items of at least `item_bytes` each, checked against the bytes left.
    fn count(&mut self, little: bool, item_bytes: usize, what: &str) -> R<usize> {
        let n = self.u32(little)? as usize;
        let left = self.bytes.len() - self.at;
        if n.saturating_mul(item_bytes) > left {
            self.at -= 4;
            return self.fail(format!(
                "{n} {what} cannot fit in the {left} bytes left of the geometry"
            ));
        }
        Ok(n)
    }

    fn geometry(&mut self, depth: usize) -> R<Value> {
        if depth > MAX_DEPTH {
            return self.fail(format!("geometries nested more than {MAX_DEPTH} deep"));
        }
        let order = self.u8()?;
        let little = match order {
            0 => false,
            1 => true,
            b => {
                self.at -= 1;
                return self.fail(format!("byte order {b} is neither 0 nor 1: not WKB"));
            }
        };
        let code = self.u32(little)?;
        let (base, z, m) = split_code(code);
        let dims = 2 + usize::from(z) + usize::from(m);
        let pos = |r: &mut Self| -> R<Value> {
            let x = r.f64(little)?;
            let y = r.f64(little)?;
            let zv = if z { Some(r.f64(little)?) } else { None };
            if m {
                r.f64(little)?;
            }
            Ok(position(x, y, zv))
        };
        let line = |r: &mut Self| -> R<Value> {
            let n = r.count(little, 8 * dims, "positions")?;
            (0..n)
                .map(|_| pos(r))
                .collect::<R<Vec<_>>>()
                .map(Value::Array)
        };
        let poly = |r: &mut Self| -> R<Value> {
            let n = r.count(little, 4, "rings")?;
            (0..n)
                .map(|_| line(r))
                .collect::<R<Vec<_>>>()
                .map(Value::Array)
        };
        let members = |r: &mut Self, want: u32| -> R<Vec<Value>> {
            let n = r.count(little, 5, "members")?;
            let mut out = Vec::with_capacity(n);
            for _ in 0..n {
                let start = r.at;
                let g = r.geometry(depth + 1)?;
                if want != 0 && g["type"] != type_name(want) {
                    r.at = start;
                    return r.fail(format!(
                        "a member of a Multi{} is a {}",
                        type_name(want),
                        g["type"]
                    ));
                }
                out.push(g);
            }
            Ok(out)
        };
        let coords = |gs: Vec<Value>| -> Vec<Value> {
            gs.into_iter()
                .map(|mut g| g["coordinates"].take())
                .collect()
        };
        match base {
            1 => {
                let p = pos(self)?;
                // An empty point is written as NaN coordinates.
                if p[0].is_null() && p[1].is_null() {
                    return Ok(json!({"type": "Point", "coordinates": []}));
                }
                Ok(json!({"type": "Point", "coordinates": p}))
            }
            2 => Ok(json!({"type": "LineString", "coordinates": line(self)?})),
            3 => Ok(json!({"type": "Polygon", "coordinates": poly(self)?})),
            4 => Ok(json!({"type": "MultiPoint", "coordinates": coords(members(self, 1)?)})),
            5 => Ok(json!({"type": "MultiLineString", "coordinates": coords(members(self, 2)?)})),
            6 => Ok(json!({"type": "MultiPolygon", "coordinates": coords(members(self, 3)?)})),
            7 => Ok(json!({"type": "GeometryCollection", "geometries": members(self, 0)?})),
            _ => {
                self.at -= 4;
                self.fail(format!(
                    "geometry type {code} is not one GeoJSON has (curves, surfaces, TINs are not read)"
                ))
            }
        }
    }
}

/// (base type 1..7, has Z, has M) of an ISO or EWKB type code.
fn split_code(code: u32) -> (u32, bool, bool) {
    let ewkb_z = code & 0x8000_0000 != 0;
    let ewkb_m = code & 0x4000_0000 != 0;
    let iso = code & 0x0fff_ffff;
    let (base, iso_z, iso_m) = match iso / 1000 {
        1 => (iso % 1000, true, false),
        2 => (iso % 1000, false, true),
        3 => (iso % 1000, true, true),
        _ => (iso % 1000, false, false),
    };
    (base, iso_z || ewkb_z, iso_m || ewkb_m)
}

fn type_name(base: u32) -> &'static str {
    match base {
        1 => "Point",
        2 => "LineString",
        3 => "Polygon",
        4 => "MultiPoint",
        5 => "MultiLineString",
        6 => "MultiPolygon",
        _ => "GeometryCollection",
    }
}

/// Reads one WKB geometry filling `bytes`.
pub fn read(bytes: &[u8]) -> Result<Value, WkbError> {
    let mut r = Reader { bytes, at: 0 };
    let g = r.geometry(0)?;
    if r.at != bytes.len() {
        return r.fail(format!("{} bytes after the geometry", bytes.len() - r.at));
    }
    Ok(g)
}

/// What a GeoPackage geometry blob holds.
pub struct GpkgGeometry {
    /// Its `srs_id`.
    pub srs_id: i32,
    /// The geometry, `null` for an empty one.
    pub geometry: Value,
}

/// Reads a GeoPackage geometry blob (`GP`, version, flags, srs_id, envelope, WKB).
pub fn read_gpkg(blob: &[u8]) -> Result<GpkgGeometry, WkbError> {
    let mut r = Reader { bytes: blob, at: 0 };
    if r.take(2)? != b"GP" {
        r.at = 0;
        return r.fail("not a GeoPackage geometry (no \"GP\" magic)");
    }
    let _version = r.u8()?;
    let flags = r.u8()?;
    if flags & 0x20 != 0 {
        r.at -= 1;
        return r.fail("an extended GeoPackage geometry (flags bit 5) is not read");
    }
    let little = flags & 1 == 1;
    let srs_id = r.u32(little)? as i32;
    let envelope = match (flags >> 1) & 7 {
        0 => 0,
        1 => 32,
        2 | 3 => 48,
        4 => 64,
        e => {
            r.at = 3;
            return r.fail(format!("envelope code {e} is not 0 to 4"));
        }
    };
    r.take(envelope)?;
    let empty = flags & 0x10 != 0;
    let start = r.at;
    let geometry = match read(&blob[start..]) {
        Ok(g) => g,
        Err(e) => {
            return Err(WkbError {
                offset: e.offset + start,
                reason: e.reason,
            })
        }
    };
    Ok(GpkgGeometry {
        srs_id,
        geometry: if empty { Value::Null } else { geometry },
    })
}

/// A GeoJSON geometry that cannot be written as WKB.
fn bad(what: &str) -> String {
    format!("the geometry cannot be written: {what}")
}

/// Writes a GeoJSON geometry as little-endian ISO WKB (Z when its first position has 3
/// numbers).
pub fn write(g: &Value, out: &mut Vec<u8>) -> Result<(), String> {
    let kind = g["type"].as_str().ok_or_else(|| bad("no type"))?;
    let z = has_z(g);
    let code = |base: u32| base + if z { 1000 } else { 0 };
    out.push(1);
    let coords = &g["coordinates"];
    let pos = |p: &Value, out: &mut Vec<u8>| -> Result<(), String> {
        let a = p
            .as_array()
            .ok_or_else(|| bad("a position is not an array"))?;
        let n = if z { 3 } else { 2 };
        for i in 0..n {
            let v = a
                .get(i)
                .and_then(Value::as_f64)
                .unwrap_or(if i == 2 { 0.0 } else { f64::NAN });
            out.extend_from_slice(&v.to_le_bytes());
        }
        Ok(())
    };
    let arr = |v: &Value| -> Result<Vec<Value>, String> {
        v.as_array()
            .cloned()
            .ok_or_else(|| bad("coordinates are not an array"))
    };
    let line = |v: &Value, out: &mut Vec<u8>| -> Result<(), String> {
        let ps = arr(v)?;
        out.extend_from_slice(&(ps.len() as u32).to_le_bytes());
        ps.iter().try_for_each(|p| pos(p, out))
    };
    let poly = |v: &Value, out: &mut Vec<u8>| -> Result<(), String> {
        let rings = arr(v)?;
        out.extend_from_slice(&(rings.len() as u32).to_le_bytes());
        rings.iter().try_for_each(|r| line(r, out))
    };
    match kind {
        "Point" => {
            out.extend_from_slice(&code(1).to_le_bytes());
            if coords.as_array().is_some_and(Vec::is_empty) {
                let n = if z { 3 } else { 2 };
                (0..n).for_each(|_| out.extend_from_slice(&f64::NAN.to_le_bytes()));
                Ok(())
            } else {
                pos(coords, out)
            }
        }
        "LineString" => {
            out.extend_from_slice(&code(2).to_le_bytes());
            line(coords, out)
        }
        "Polygon" => {
            out.extend_from_slice(&code(3).to_le_bytes());
            poly(coords, out)
        }
        "MultiPoint" | "MultiLineString" | "MultiPolygon" => {
            let (base, member) = match kind {
                "MultiPoint" => (4, "Point"),
                "MultiLineString" => (5, "LineString"),
                _ => (6, "Polygon"),
            };
            out.extend_from_slice(&code(base).to_le_bytes());
            let parts = arr(coords)?;
            out.extend_from_slice(&(parts.len() as u32).to_le_bytes());
            for p in parts {
                let mut g = json!({"type": member, "coordinates": p});
                if z {
                    force_z(&mut g);
                }
                write(&g, out)?;
            }
            Ok(())
        }
        "GeometryCollection" => {
            out.extend_from_slice(&code(7).to_le_bytes());
            let parts = arr(&g["geometries"])?;
            out.extend_from_slice(&(parts.len() as u32).to_le_bytes());
            parts.iter().try_for_each(|p| write(p, out))
        }
        other => Err(bad(&format!("type {other:?}"))),
    }
}

/// Makes the first position of a geometry have 3 numbers, so that [`has_z`] says so for
/// members written on their own.
fn force_z(g: &mut Value) {
    let mut c = &mut g["coordinates"];
    while c
        .as_array()
        .and_then(|a| a.first())
        .is_some_and(Value::is_array)
    {
        c = &mut c[0];
    }
    if let Some(a) = c.as_array_mut() {
        if a.len() == 2 {
            a.push(number(0.0));
        }
    }
}

/// True when the geometry's first position has an altitude.
pub fn has_z(g: &Value) -> bool {
    let mut c = &g["coordinates"];
    if g["type"] == "GeometryCollection" {
        return g["geometries"]
            .as_array()
            .and_then(|a| a.first())
            .is_some_and(has_z);
    }
    while let Some(first) = c.as_array().and_then(|a| a.first()) {
        if first.is_number() {
            return c.as_array().is_some_and(|a| a.len() >= 3);
        }
        c = first;
    }
    false
}

/// The envelope `[min x, max x, min y, max y]` of a geometry's positions, `None` when it has
/// none.
pub fn envelope(g: &Value) -> Option<[f64; 4]> {
    fn walk(v: &Value, e: &mut Option<[f64; 4]>) {
        match v {
            Value::Array(a) if a.first().is_some_and(Value::is_number) => {
                if let (Some(x), Some(y)) = (a[0].as_f64(), a.get(1).and_then(Value::as_f64)) {
                    let b = e.get_or_insert([x, x, y, y]);
                    b[0] = b[0].min(x);
                    b[1] = b[1].max(x);
                    b[2] = b[2].min(y);
                    b[3] = b[3].max(y);
                }
            }
            Value::Array(a) => a.iter().for_each(|x| walk(x, e)),
            _ => {}
        }
    }
    let mut e = None;
    if let Some(gs) = g["geometries"].as_array() {
        gs.iter().for_each(|m| walk(&m["coordinates"], &mut e));
    } else {
        walk(&g["coordinates"], &mut e);
    }
    e
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips_and_refuses_truncation() {
        let geoms = [
            json!({"type": "Point", "coordinates": [1.5, 2.0]}),
            json!({"type": "LineString", "coordinates": [[0.0, 0.0, 5.0], [1.0, 1.0, 6.0]]}),
            json!({"type": "MultiPolygon", "coordinates": [[[[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 0.0]]]]}),
            json!({"type": "GeometryCollection", "geometries": [{"type": "Point", "coordinates": [3.0, 4.0]}]}),
        ];
        for g in geoms {
            let mut b = Vec::new();
            write(&g, &mut b).unwrap();
            assert_eq!(read(&b).unwrap(), g);
            for cut in 0..b.len() {
                let e = read(&b[..cut]).unwrap_err();
                assert!(e.offset <= cut, "{} > {cut}", e.offset);
            }
        }
        // A count far beyond the bytes: refused before allocating.
        let mut b = vec![1u8];
        b.extend_from_slice(&2u32.to_le_bytes());
        b.extend_from_slice(&u32::MAX.to_le_bytes());
        let e = read(&b).unwrap_err();
        assert_eq!(e.offset, 5);
        assert!(e.reason.contains("4294967295 positions"), "{}", e.reason);
    }

    #[test]
    fn reads_a_gpkg_blob_with_envelope() {
        let g = json!({"type": "Point", "coordinates": [10.0, 20.0]});
        let mut b = b"GP\x00\x03".to_vec(); // little-endian header, 32-byte envelope
        b.extend_from_slice(&4326u32.to_le_bytes());
        for v in [10.0f64, 10.0, 20.0, 20.0] {
            b.extend_from_slice(&v.to_le_bytes());
        }
        write(&g, &mut b).unwrap();
        let r = read_gpkg(&b).unwrap();
        assert_eq!((r.srs_id, r.geometry), (4326, g));
        assert!(read_gpkg(b"XP\x00\x01").is_err());
    }
}
