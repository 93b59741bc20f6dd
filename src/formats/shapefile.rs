//! ESRI Shapefile: `.shp` (geometry) + `.dbf` (attributes) + `.prj` (CRS) + `.cpg` (text
//! encoding), or one `.zip` holding them (each `.shp` in it a layer, named by its stem).
//!
//! The `.shp` is read record by record (the `.shx` index is not needed: records follow one
//! another); each record's attributes come from the `.dbf` record of the same number. Shape
//! types: points, multipoints, polylines and polygons, plain, with M, and with Z (the Z kept as
//! the third number); a null shape is a feature with a `null` geometry. A polygon's rings are
//! grouped as the format defines them: a clockwise ring is an outer ring, a counter-clockwise
//! one a hole of the outer ring that contains it (or of the last outer ring before it).

use crate::formats::crs::Crs;
use crate::formats::dbf::{DbfReader, Encoding};
use crate::formats::{feature, position, FeatureResult, FormatError, Layer, ReadOptions};
use serde_json::{json, Map, Value};
use std::fs::File;
use std::io::{self, BufReader, Cursor, Read};
use std::path::{Path, PathBuf};

/// A zip member larger than this is refused (zip members are read into memory).
pub const MAX_ZIP_MEMBER_BYTES: u64 = 2 << 30;

/// The length of a `.shp` file header; the first record follows it.
const SHP_HEADER: u64 = 100;

type Input = Box<dyn Read + Send>;

/// The files of one shapefile layer.
struct Files {
    name: String,
    shp: Input,
    dbf: Option<Input>,
    prj: Option<String>,
    cpg: Option<String>,
    /// How the `.shp` is named in messages.
    shp_name: String,
    dbf_name: String,
}

/// Opens a `.shp` (or `.dbf`) and its siblings, or a `.zip`.
pub fn open(path: &Path, name: &str, options: &ReadOptions) -> Result<Vec<Layer>, FormatError> {
    let mut head = [0u8; 4];
    let n = File::open(path)
        .and_then(|mut f| f.read(&mut head))
        .map_err(|e| FormatError::file(name, format!("cannot open: {e}")))?;
    let files = if head[..n] == *b"PK\x03\x04" {
        zipped(path, name, options)?
    } else {
        super::single_layer(name, super::Kind::Shapefile, options)?;
        vec![siblings(path, name)?]
    };
    files.into_iter().map(layer).collect()
}

/// A sibling of `path` with extension `ext` (either case), if it exists.
fn sibling(path: &Path, ext: &str) -> Option<PathBuf> {
    [ext.to_string(), ext.to_ascii_uppercase()]
        .into_iter()
        .map(|e| path.with_extension(e))
        .find(|p| p.is_file())
}

fn siblings(path: &Path, name: &str) -> Result<Files, FormatError> {
    let shp_path = sibling(path, "shp").ok_or_else(|| {
        FormatError::file(
            name,
            "no .shp beside it: a Shapefile is a .shp with its .dbf",
        )
    })?;
    let open = |p: &Path| -> Result<Input, FormatError> {
        File::open(p)
            .map(|f| Box::new(BufReader::with_capacity(256 << 10, f)) as Input)
            .map_err(|e| FormatError::file(&p.display().to_string(), format!("cannot open: {e}")))
    };
    let text = |p: Option<PathBuf>| -> Result<Option<String>, FormatError> {
        p.map(|p| {
            std::fs::read(&p)
                .map(|b| String::from_utf8_lossy(&b).into_owned())
                .map_err(|e| {
                    FormatError::file(&p.display().to_string(), format!("cannot read: {e}"))
                })
        })
        .transpose()
    };
    let dbf_path = sibling(path, "dbf");
    Ok(Files {
        name: shp_path
            .file_stem()
            .map_or_else(String::new, |s| s.to_string_lossy().into_owned()),
        shp: open(&shp_path)?,
        dbf: dbf_path.as_deref().map(open).transpose()?,
        prj: text(sibling(path, "prj"))?,
        cpg: text(sibling(path, "cpg"))?,
        shp_name: shp_path.display().to_string(),
        dbf_name: dbf_path.map_or_else(String::new, |p| p.display().to_string()),
    })
}

/// The layers of a zipped shapefile (one per `.shp` member).
fn zipped(path: &Path, name: &str, options: &ReadOptions) -> Result<Vec<Files>, FormatError> {
    let file =
        File::open(path).map_err(|e| FormatError::file(name, format!("cannot open: {e}")))?;
    let mut zip = zip::ZipArchive::new(BufReader::new(file))
        .map_err(|e| FormatError::file(name, format!("not a readable zip archive: {e}")))?;
    let names: Vec<String> = zip.file_names().map(str::to_string).collect();
    let mut stems: Vec<&str> = names
        .iter()
        .filter(|n| n.to_ascii_lowercase().ends_with(".shp") && !n.contains("__MACOSX"))
        .map(|n| &n[..n.len() - 4])
        .collect();
    stems.sort_by_key(|s| names.iter().position(|n| n.starts_with(s)));
    if stems.is_empty() {
        return Err(FormatError::file(name, "the zip archive holds no .shp"));
    }
    let layer_of = |stem: &str| stem.rsplit('/').next().unwrap_or(stem).to_string();
    if let Some(l) = &options.layer {
        stems.retain(|s| layer_of(s) == *l);
        if stems.is_empty() {
            return Err(FormatError::file(
                name,
                format!("--layer {l:?}: the zip archive has no {l}.shp"),
            ));
        }
    }
    let mut member = |stem: &str, ext: &str| -> Result<Option<(Vec<u8>, String)>, FormatError> {
        let Some(full) = names.iter().find(|n| {
            n.len() == stem.len() + 4
                && n.starts_with(stem)
                && n[stem.len()..].eq_ignore_ascii_case(ext)
        }) else {
            return Ok(None);
        };
        let label = format!("{name}/{full}");
        let mut f = zip
            .by_name(full)
            .map_err(|e| FormatError::file(&label, format!("cannot read from the zip: {e}")))?;
        if f.size() > MAX_ZIP_MEMBER_BYTES {
            return Err(FormatError::file(
                &label,
                format!("{} bytes: zip members of at most {MAX_ZIP_MEMBER_BYTES} bytes are read; unzip it first", f.size()),
            ));
        }
        let mut b = Vec::with_capacity(f.size() as usize);
        f.read_to_end(&mut b)
            .map_err(|e| FormatError::file(&label, format!("cannot read from the zip: {e}")))?;
        Ok(Some((b, label)))
    };
    let mut out = Vec::new();
    for stem in stems {
        let (shp, shp_name) = member(stem, ".shp")?.unwrap_or_default();
        let dbf = member(stem, ".dbf")?;
        let prj = member(stem, ".prj")?.map(|(b, _)| String::from_utf8_lossy(&b).into_owned());
        let cpg = member(stem, ".cpg")?.map(|(b, _)| String::from_utf8_lossy(&b).into_owned());
        let dbf_name = dbf.as_ref().map_or_else(String::new, |(_, n)| n.clone());
        out.push(Files {
            name: layer_of(stem),
            shp: Box::new(Cursor::new(shp)),
            dbf: dbf.map(|(b, _)| Box::new(Cursor::new(b)) as Input),
            prj,
            cpg,
            shp_name,
            dbf_name,
        });
    }
    Ok(out)
}

/// One layer of a shapefile.
fn layer(f: Files) -> Result<Layer, FormatError> {
    let crs = match &f.prj {
        Some(wkt) if !wkt.trim().is_empty() => Crs::from_wkt(wkt)
            .map_err(|e| FormatError::file(&f.shp_name, format!("{e} (from its .prj)")))?,
        _ => Crs::unstated(),
    };
    let encoding = match &f.cpg {
        Some(t) => Encoding::from_cpg(t).map_err(|e| FormatError::file(&f.shp_name, e))?,
        None => Encoding::Unstated,
    };
    let dbf = match f.dbf {
        Some(r) => Some(DbfReader::new(r, &f.dbf_name, encoding)?),
        None => None,
    };
    let mut shp = f.shp;
    let mut head = [0u8; 100];
    shp.read_exact(&mut head).map_err(|e| {
        FormatError::file(
            &f.shp_name,
            format!("the file header is truncated or unreadable: {e}"),
        )
        .at_byte(0)
    })?;
    if head[..4] != [0, 0, 0x27, 0x0a] {
        return Err(
            FormatError::file(&f.shp_name, "not a .shp file (no file code 9994)").at_byte(0),
        );
    }
    let length = u64::from(u32::from_be_bytes([head[24], head[25], head[26], head[27]])) * 2;
    let reader = ShpRecords {
        shp,
        dbf,
        file: f.shp_name,
        at: SHP_HEADER,
        length,
        number: 0,
        crs: crs.clone(),
        done: false,
    };
    Ok(Layer {
        name: f.name,
        crs,
        features: Box::new(reader),
    })
}

/// The records of a `.shp` with their `.dbf` attributes.
struct ShpRecords {
    shp: Input,
    dbf: Option<DbfReader<Input>>,
    file: String,
    /// Byte offset of the next record.
    at: u64,
    /// The file length the header states.
    length: u64,
    number: u64,
    crs: Crs,
    done: bool,
}

impl Iterator for ShpRecords {
    type Item = FeatureResult;

    fn next(&mut self) -> Option<FeatureResult> {
        loop {
            if self.done {
                return None;
            }
            match self.record() {
                Ok(Some(f)) => return Some(Ok(f)),
                Ok(None) if self.done => return None,
                Ok(None) => continue,
                Err(e) => {
                    self.done = true;
                    return Some(Err(e));
                }
            }
        }
    }
}

impl ShpRecords {
    /// The next feature; `Ok(None)` at the end (with `done`) or for a deleted record.
    fn record(&mut self) -> Result<Option<Value>, FormatError> {
        let start = self.at;
        let mut h = [0u8; 8];
        match read_some(&mut self.shp, &mut h) {
            Ok(0) => {
                self.done = true;
                return self.end();
            }
            Ok(8) => {}
            Ok(_) => {
                return Err(self.fail(
                    start,
                    "the record header is truncated (the file ends early)",
                ))
            }
            Err(e) => return Err(self.fail(start, &format!("cannot read: {e}"))),
        }
        self.number += 1;
        let content = u64::from(u32::from_be_bytes([h[4], h[5], h[6], h[7]])) * 2;
        if self.length >= SHP_HEADER && start + 8 + content > self.length {
            return Err(self.fail(
                start + 4,
                &format!(
                    "the record's length ({content} bytes) runs past the end the header states ({} bytes): the file is corrupt",
                    self.length
                ),
            ));
        }
        let mut body = Vec::new();
        let read = (&mut self.shp).take(content).read_to_end(&mut body);
        let got = read.map_err(|e| self.fail(start + 8, &format!("cannot read: {e}")))?;
        if (got as u64) < content {
            return Err(self.fail(
                start + 8 + got as u64,
                &format!("the record is truncated: {content} bytes stated, {got} in the file"),
            ));
        }
        self.at = start + 8 + content;
        let mut geometry =
            shape(&body).map_err(|(off, why)| self.fail(start + 8 + off as u64, &why))?;
        self.crs
            .to_lonlat(&mut geometry)
            .map_err(|why| self.fail(start + 8, &why))?;
        let next = self.dbf.as_mut().map(|d| (d.next_record(), d.len()));
        let properties = match next {
            Some((Some(Ok(Some(p))), _)) => p,
            Some((Some(Ok(None)), _)) => return Ok(None),
            Some((Some(Err(e)), _)) => return Err(e),
            Some((None, n)) => {
                return Err(self.fail(
                    start,
                    &format!("the .dbf has fewer records ({n}) than the .shp"),
                ))
            }
            None => Map::new(),
        };
        Ok(Some(feature(geometry, properties, None)))
    }

    /// At the end of the `.shp`: the `.dbf` must have ended too.
    fn end(&mut self) -> Result<Option<Value>, FormatError> {
        if let Some(d) = &mut self.dbf {
            if d.next_record().is_some() {
                return Err(FormatError::file(
                    &self.file,
                    format!(
                        "the .shp has {} records but the .dbf has {}: the files do not belong together or one is truncated",
                        self.number,
                        d.len()
                    ),
                )
                .at_byte(self.at));
            }
        }
        Ok(None)
    }

    fn fail(&self, byte: u64, why: &str) -> FormatError {
        FormatError::file(&self.file, why)
            .at_record(self.number.max(1))
            .at_byte(byte)
    }
}

/// Reads up to `buf.len()` bytes; fewer only at the end of the input.
fn read_some(r: &mut impl Read, buf: &mut [u8]) -> io::Result<usize> {
    let mut n = 0;
    while n < buf.len() {
        match r.read(&mut buf[n..]) {
            Ok(0) => break,
            Ok(k) => n += k,
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(n)
}

/// A little-endian reader over a record's content; errors carry the offset within it.
struct Content<'a> {
    b: &'a [u8],
    at: usize,
}

type Shaped<T> = Result<T, (usize, String)>;

impl Content<'_> {
    fn need(&self, n: usize, what: &str) -> Shaped<()> {
        if self.b.len() - self.at < n {
            return Err((
                self.at,
                format!(
                    "the shape is shorter than its {what} need ({n} bytes, {} left)",
                    self.b.len() - self.at
                ),
            ));
        }
        Ok(())
    }
    fn i32(&mut self) -> Shaped<i32> {
        self.need(4, "counts")?;
        let v = i32::from_le_bytes(self.b[self.at..self.at + 4].try_into().unwrap_or([0; 4]));
        self.at += 4;
        Ok(v)
    }
    fn f64(&mut self) -> f64 {
        let v = f64::from_le_bytes(self.b[self.at..self.at + 8].try_into().unwrap_or([0; 8]));
        self.at += 8;
        v
    }
    fn count(&mut self, what: &str, each: usize) -> Shaped<usize> {
        let at = self.at;
        let n = self.i32()?;
        let left = self.b.len() - self.at;
        if n < 0 || (n as usize).saturating_mul(each) > left {
            return Err((
                at,
                format!("{n} {what} cannot fit in the {left} bytes left of the shape"),
            ));
        }
        Ok(n as usize)
    }
}

/// The GeoJSON geometry of one record's content.
fn shape(b: &[u8]) -> Shaped<Value> {
    let mut c = Content { b, at: 0 };
    let kind = c.i32()?;
    let (base, z, m) = match kind {
        0 => return Ok(Value::Null),
        1 | 3 | 5 | 8 => (kind, false, false),
        11 | 13 | 15 | 18 => (kind - 10, true, true),
        21 | 23 | 25 | 28 => (kind - 20, false, true),
        31 => {
            return Err((
                0,
                "a MultiPatch shape (type 31) has no GeoJSON geometry".into(),
            ))
        }
        t => return Err((0, format!("shape type {t} is not a Shapefile shape type"))),
    };
    if base == 1 {
        c.need(16 + if z { 8 } else { 0 }, "coordinates")?;
        let (x, y) = (c.f64(), c.f64());
        let zv = z.then(|| c.f64());
        return Ok(json!({"type": "Point", "coordinates": position(x, y, zv)}));
    }
    c.need(32, "bounding box")?;
    c.at += 32;
    let parts = if base == 8 { 0 } else { c.count("parts", 4)? };
    let per_point = 16;
    let points = c.count("points", per_point)?;
    let mut starts = Vec::with_capacity(parts);
    for _ in 0..parts {
        let at = c.at;
        let s = c.i32()?;
        if s < 0 || s as usize > points || starts.last().is_some_and(|&p: &usize| p > s as usize) {
            return Err((
                at,
                format!("part start {s} is not within the {points} points in order"),
            ));
        }
        starts.push(s as usize);
    }
    c.need(points * per_point, "points")?;
    let mut xy = Vec::with_capacity(points);
    for _ in 0..points {
        xy.push((c.f64(), c.f64()));
    }
    let mut zs = None;
    // Z (types 1x) then M: the Z range and values, when the content holds them.
    if z && c.b.len() - c.at >= 16 + 8 * points {
        c.at += 16;
        zs = Some((0..points).map(|_| c.f64()).collect::<Vec<_>>());
    }
    let _ = m;
    let pos = |i: usize| position(xy[i].0, xy[i].1, zs.as_ref().map(|z| z[i]));
    if base == 8 {
        let ps: Vec<Value> = (0..points).map(pos).collect();
        return Ok(json!({"type": "MultiPoint", "coordinates": ps}));
    }
    let mut rings: Vec<(usize, usize)> = Vec::with_capacity(parts);
    for (i, &s) in starts.iter().enumerate() {
        let e = starts.get(i + 1).copied().unwrap_or(points);
        if e > s {
            rings.push((s, e));
        }
    }
    let line = |(s, e): (usize, usize)| Value::Array((s..e).map(pos).collect());
    if base == 3 {
        let lines: Vec<Value> = rings.iter().map(|&r| line(r)).collect();
        return Ok(match lines.len() {
            0 => Value::Null,
            1 => json!({"type": "LineString", "coordinates": lines[0]}),
            _ => json!({"type": "MultiLineString", "coordinates": lines}),
        });
    }
    // Polygons: clockwise rings are outer rings, counter-clockwise ones holes.
    let mut polygons: Vec<(usize, Vec<(usize, usize)>)> = Vec::new();
    let mut holes = Vec::new();
    for &r in &rings {
        if signed_area(&xy[r.0..r.1]) <= 0.0 {
            polygons.push((r.0, vec![r]));
        } else {
            holes.push(r);
        }
    }
    for h in holes {
        let (hx, hy) = xy[h.0];
        let owner = polygons
            .iter()
            .position(|(_, rs)| contains(&xy[rs[0].0..rs[0].1], hx, hy))
            .or_else(|| polygons.iter().rposition(|(s, _)| *s < h.0));
        match owner {
            Some(i) => polygons[i].1.push(h),
            // A hole with no outer ring: GDAL makes it a polygon of its own; so do we.
            None => polygons.push((h.0, vec![h])),
        }
    }
    polygons.sort_by_key(|(s, _)| *s);
    let polys: Vec<Value> = polygons
        .into_iter()
        .map(|(_, rs)| Value::Array(rs.into_iter().map(line).collect()))
        .collect();
    Ok(match polys.len() {
        0 => Value::Null,
        1 => json!({"type": "Polygon", "coordinates": polys[0]}),
        _ => json!({"type": "MultiPolygon", "coordinates": polys}),
    })
}

/// Twice the signed planar area (positive counter-clockwise).
fn signed_area(ring: &[(f64, f64)]) -> f64 {
    let n = ring.len();
    (0..n)
        .map(|i| {
            let (a, b) = (ring[i], ring[(i + 1) % n]);
            a.0 * b.1 - b.0 * a.1
        })
        .sum()
}

/// Planar point in ring (even-odd).
fn contains(ring: &[(f64, f64)], x: f64, y: f64) -> bool {
    let mut inside = false;
    let n = ring.len();
    let mut j = n.wrapping_sub(1);
    for i in 0..n {
        let (xi, yi) = ring[i];
        let (xj, yj) = ring[j];
        if (yi > y) != (yj > y) && x < (xj - xi) * (y - yi) / (yj - yi) + xi {
            inside = !inside;
        }
        j = i;
    }
    inside
}

#[cfg(test)]
mod tests {
    use super::*;

    fn record(kind: i32, parts: &[i32], pts: &[(f64, f64)]) -> Vec<u8> {
        let mut b = kind.to_le_bytes().to_vec();
        b.extend([0u8; 32]);
        b.extend((parts.len() as i32).to_le_bytes());
        b.extend((pts.len() as i32).to_le_bytes());
        parts.iter().for_each(|p| b.extend(p.to_le_bytes()));
        for (x, y) in pts {
            b.extend(x.to_le_bytes());
            b.extend(y.to_le_bytes());
        }
        b
    }

    #[test]
    fn polygon_rings_grouped_by_orientation() {
        // Outer (clockwise) 0..10 square, hole (counter-clockwise) inside, second outer apart.
        let outer = [
            (0.0, 0.0),
            (0.0, 10.0),
            (10.0, 10.0),
            (10.0, 0.0),
            (0.0, 0.0),
        ];
        let other = [
            (20.0, 0.0),
            (20.0, 1.0),
            (21.0, 1.0),
            (21.0, 0.0),
            (20.0, 0.0),
        ];
        let hole = [(2.0, 2.0), (4.0, 2.0), (4.0, 4.0), (2.0, 4.0), (2.0, 2.0)];
        let pts: Vec<_> = outer.iter().chain(&other).chain(&hole).copied().collect();
        let g = shape(&record(5, &[0, 5, 10], &pts)).unwrap();
        assert_eq!(g["type"], "MultiPolygon");
        assert_eq!(g["coordinates"][0].as_array().unwrap().len(), 2, "{g}");
        assert_eq!(g["coordinates"][1].as_array().unwrap().len(), 1);
        // Corrupt counts and truncation are errors with offsets, not panics.
        let mut b = record(3, &[0], &[(0.0, 0.0), (1.0, 1.0)]);
        b[40..44].copy_from_slice(&i32::MAX.to_le_bytes());
        let (at, why) = shape(&b).unwrap_err();
        assert_eq!(at, 40);
        assert!(why.contains("2147483647 points"), "{why}");
        let b = record(3, &[0], &[(0.0, 0.0), (1.0, 1.0)]);
        for cut in 0..b.len() {
            assert!(shape(&b[..cut]).is_err());
        }
    }
}
