//! The files people have: Shapefile, GeoPackage, FlatGeobuf, GPX and TopoJSON read as a stream
//! of GeoJSON `Feature` values, and written from the output features (feature `formats`).
//!
//! # Reading
//! [`open`] finds the format ([`Kind::detect`]: by the file's first bytes, then its extension),
//! opens every layer (or the one `layer` names) and returns a [`Source`]: its layers, each with
//! the CRS its coordinates came in and an iterator of features. Each feature is a GeoJSON
//! `Feature` ([`serde_json::Value`]) with its attributes as `properties` (numbers as numbers,
//! text as strings, booleans, dates as `YYYY-MM-DD` strings, NULL as `null`), in the file's
//! order, with `id` where the format has one (a GeoPackage's feature id, a TopoJSON object's
//! `id`).
//!
//! * **Shapefile** ([`shapefile`]): `.shp` + `.dbf` (+ `.prj`, `.cpg`), or one `.zip` holding
//!   them; read record by record, never whole (a zip's members are read into memory).
//! * **GeoPackage** ([`geopackage`]): every feature table listed in `gpkg_contents`, or the one
//!   named; rows are fetched in pages of [`geopackage::PAGE_ROWS`] in feature-id order.
//! * **FlatGeobuf** ([`flatgeobuf`]): read feature by feature.
//! * **GPX** ([`gpx`]): a track is one `LineString` (a `MultiLineString` for several segments)
//!   whose `properties.coordTimes` holds each point's `<time>` (RFC 3339), the time
//!   parameterisation [`crate::earth::time`] reads; routes are `LineString`s, waypoints
//!   `Point`s.
//! * **TopoJSON** ([`topojson`]): each object's geometries decoded from the arcs (quantised
//!   and delta-encoded or not); every object, or the one `layer` names.
//!
//! # Coordinate reference systems ([`crs`])
//! Coordinates in EPSG:4326 / CRS84 (or a file that states no CRS) pass unchanged; a CRS named
//! by an EPSG code (a GeoPackage `srs_id`, a `.prj` whose WKT names an authority or a known
//! name, a FlatGeobuf header's code) is transformed to lon/lat with `proj4rs` as the features
//! are read; any other CRS is refused with an error naming it.
//!
//! # Errors
//! A [`FormatError`] names the file, the layer, the record (1-based) and the byte offset
//! where the reading failed, as far as they are known; nothing in a file makes the reader
//! panic.
//!
//! # Writing ([`mod@write`])
//! [`write::FeatureWriter`] takes output features one by one and writes a GeoPackage,
//! FlatGeobuf, Shapefile or GPX file at the end (the features are spooled to a temporary file
//! beside the output first: the schema of the table is known only once every feature is).

pub mod crs;
mod dbf;
pub mod flatgeobuf;
pub mod geopackage;
pub mod gpx;
pub mod shapefile;
pub mod topojson;
mod wkb;
pub mod write;

use serde_json::Value;
use std::fmt;
use std::path::Path;

pub use crs::Crs;

/// The formats this module reads and writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// ESRI Shapefile (`.shp` with its `.dbf`, `.prj`, `.cpg`), or a `.zip` holding one.
    Shapefile,
    /// OGC GeoPackage (an SQLite database).
    GeoPackage,
    /// FlatGeobuf.
    FlatGeobuf,
    /// GPX 1.0 / 1.1.
    Gpx,
    /// TopoJSON.
    TopoJson,
}

/// The magic bytes at the start of an SQLite database (a GeoPackage).
const SQLITE_MAGIC: &[u8] = b"SQLite format 3\0";
/// The magic bytes at the start of a FlatGeobuf file (`fgb`, major version 3).
const FGB_MAGIC: &[u8] = b"fgb\x03";
/// The file code at the start of a `.shp` (9994, big-endian).
const SHP_MAGIC: &[u8] = &[0, 0, 0x27, 0x0a];
/// The start of a zip archive's first local file header.
const ZIP_MAGIC: &[u8] = b"PK\x03\x04";

impl Kind {
    /// The format of a file from its first bytes (`head`, a few hundred are enough) or, failing
    /// that, its extension. `None`: not one of these formats (GeoJSON and its sequences are
    /// the command line's own).
    pub fn detect(path: Option<&Path>, head: &[u8]) -> Option<Kind> {
        if head.starts_with(SQLITE_MAGIC) {
            return Some(Kind::GeoPackage);
        }
        if head.starts_with(FGB_MAGIC) {
            return Some(Kind::FlatGeobuf);
        }
        if head.starts_with(SHP_MAGIC) || head.starts_with(ZIP_MAGIC) {
            return Some(Kind::Shapefile);
        }
        let ext = path
            .and_then(|p| p.extension())
            .map(|e| e.to_string_lossy().to_ascii_lowercase());
        match ext.as_deref() {
            Some("shp" | "dbf" | "zip") => return Some(Kind::Shapefile),
            Some("gpkg") => return Some(Kind::GeoPackage),
            Some("fgb") => return Some(Kind::FlatGeobuf),
            Some("gpx") => return Some(Kind::Gpx),
            Some("topojson") => return Some(Kind::TopoJson),
            _ => {}
        }
        let text = String::from_utf8_lossy(&head[..head.len().min(1024)]);
        let text = text.trim_start_matches('\u{feff}').trim_start();
        if text.starts_with("<?xml") || text.starts_with("<gpx") {
            return text.contains("<gpx").then_some(Kind::Gpx);
        }
        if text.starts_with('{') {
            let compact: String = text.chars().filter(|c| !c.is_whitespace()).collect();
            if compact.starts_with("{\"type\":\"Topology\"") {
                return Some(Kind::TopoJson);
            }
        }
        None
    }

    /// The format an output file's extension asks for.
    pub fn from_extension(path: &Path) -> Option<Kind> {
        let ext = path.extension()?.to_string_lossy().to_ascii_lowercase();
        match ext.as_str() {
            "shp" => Some(Kind::Shapefile),
            "gpkg" => Some(Kind::GeoPackage),
            "fgb" => Some(Kind::FlatGeobuf),
            "gpx" => Some(Kind::Gpx),
            "topojson" => Some(Kind::TopoJson),
            _ => None,
        }
    }

    /// The format's name in messages.
    pub fn name(self) -> &'static str {
        match self {
            Kind::Shapefile => "Shapefile",
            Kind::GeoPackage => "GeoPackage",
            Kind::FlatGeobuf => "FlatGeobuf",
            Kind::Gpx => "GPX",
            Kind::TopoJson => "TopoJSON",
        }
    }
}

/// Why a file could not be read (or written): where, as far as it is known, and why.
#[derive(Clone, Debug, PartialEq)]
pub struct FormatError {
    /// The file, as named on the command line.
    pub file: String,
    /// The layer (GeoPackage table, TopoJSON object), when the file has several.
    pub layer: Option<String>,
    /// The record (feature, row, shape), 1-based.
    pub record: Option<u64>,
    /// The byte offset in the file (or the zip member) where the problem was found.
    pub byte: Option<u64>,
    /// What is wrong, for a person to fix.
    pub reason: String,
}

impl FormatError {
    /// An error of the file as a whole.
    pub fn file(file: &str, reason: impl Into<String>) -> FormatError {
        FormatError {
            file: file.to_string(),
            layer: None,
            record: None,
            byte: None,
            reason: reason.into(),
        }
    }

    /// The same error in `layer`.
    pub fn in_layer(mut self, layer: &str) -> FormatError {
        self.layer = Some(layer.to_string());
        self
    }

    /// The same error at `record` (1-based).
    pub fn at_record(mut self, record: u64) -> FormatError {
        self.record = Some(record);
        self
    }

    /// The same error at byte `byte`.
    pub fn at_byte(mut self, byte: u64) -> FormatError {
        self.byte = Some(byte);
        self
    }
}

impl fmt::Display for FormatError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.file)?;
        if let Some(l) = &self.layer {
            write!(f, ": layer {l:?}")?;
        }
        if let Some(r) = self.record {
            write!(f, ": record {r}")?;
        }
        if let Some(b) = self.byte {
            write!(f, ": byte {b}")?;
        }
        write!(f, ": {}", self.reason)
    }
}

impl std::error::Error for FormatError {}

/// One feature read, or why it could not be.
pub type FeatureResult = Result<Value, FormatError>;

/// The features of a layer, in the file's order, in lon/lat.
pub type Features = Box<dyn Iterator<Item = FeatureResult> + Send>;

/// One layer of a file.
pub struct Layer {
    /// Its name (the table, the object, the file's stem).
    pub name: String,
    /// The CRS its coordinates came in (they are given in lon/lat).
    pub crs: Crs,
    /// Its features, read as they are asked for.
    pub features: Features,
}

/// A file opened for reading.
pub struct Source {
    /// Its format.
    pub kind: Kind,
    /// Its layers, in the file's order (only the one asked for with a layer name).
    pub layers: Vec<Layer>,
}

/// Options of [`open`].
#[derive(Clone, Debug, Default)]
pub struct ReadOptions {
    /// Read only this layer (GeoPackage table, TopoJSON object); an error when there is none
    /// of that name.
    pub layer: Option<String>,
}

/// Opens `path` (named `name` in messages) as `kind`.
///
/// # Errors
/// The file cannot be opened, is not a file of that format, has no layer of the name asked,
/// or is in a CRS that cannot be transformed to lon/lat.
pub fn open(
    path: &Path,
    name: &str,
    kind: Kind,
    options: &ReadOptions,
) -> Result<Source, FormatError> {
    let layers = match kind {
        Kind::Shapefile => shapefile::open(path, name, options)?,
        Kind::GeoPackage => geopackage::open(path, name, options)?,
        Kind::FlatGeobuf => flatgeobuf::open(path, name, options)?,
        Kind::Gpx => gpx::open(path, name, options)?,
        Kind::TopoJson => topojson::open(path, name, options)?,
    };
    Ok(Source { kind, layers })
}

/// Refuses a layer name for a format that has one layer only.
fn single_layer(name: &str, kind: Kind, options: &ReadOptions) -> Result<(), FormatError> {
    match &options.layer {
        Some(l) => Err(FormatError::file(
            name,
            format!(
                "--layer {l:?}: a {} file has one layer; leave --layer out",
                kind.name()
            ),
        )),
        None => Ok(()),
    }
}

/// A GeoJSON `Feature` of `geometry` (or `null`), `properties` and an optional `id`.
fn feature(
    geometry: Value,
    properties: serde_json::Map<String, Value>,
    id: Option<Value>,
) -> Value {
    let mut f = serde_json::Map::with_capacity(4);
    f.insert("type".into(), Value::from("Feature"));
    if let Some(id) = id {
        f.insert("id".into(), id);
    }
    f.insert("geometry".into(), geometry);
    f.insert("properties".into(), Value::Object(properties));
    Value::Object(f)
}

/// A JSON number of `x`, `null` when it is not finite (JSON has no NaN).
fn number(x: f64) -> Value {
    serde_json::Number::from_f64(x).map_or(Value::Null, Value::Number)
}

/// A position `[x, y]` or `[x, y, z]`.
fn position(x: f64, y: f64, z: Option<f64>) -> Value {
    match z {
        Some(z) => Value::Array(vec![number(x), number(y), number(z)]),
        None => Value::Array(vec![number(x), number(y)]),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn detects_by_magic_then_extension() {
        let p = Path::new("a.bin");
        assert_eq!(
            Kind::detect(Some(p), b"SQLite format 3\0xx"),
            Some(Kind::GeoPackage)
        );
        assert_eq!(
            Kind::detect(Some(p), b"fgb\x03\x00"),
            Some(Kind::FlatGeobuf)
        );
        assert_eq!(
            Kind::detect(Some(p), &[0, 0, 0x27, 0x0a, 0]),
            Some(Kind::Shapefile)
        );
        assert_eq!(Kind::detect(Some(p), b"PK\x03\x04"), Some(Kind::Shapefile));
        assert_eq!(
            Kind::detect(Some(p), b"<?xml version=\"1.0\"?>\n<gpx version=\"1.1\">"),
            Some(Kind::Gpx)
        );
        assert_eq!(
            Kind::detect(Some(p), b" { \"type\" : \"Topology\", \"arcs\": []}"),
            Some(Kind::TopoJson)
        );
        assert_eq!(
            Kind::detect(Some(p), b"{\"type\":\"FeatureCollection\"}"),
            None
        );
        assert_eq!(
            Kind::detect(Some(Path::new("x.GPKG")), b""),
            Some(Kind::GeoPackage)
        );
        assert_eq!(Kind::detect(None, b"{}"), None);
    }

    #[test]
    fn error_names_file_layer_record_byte() {
        let e = FormatError::file("a.gpkg", "bad blob")
            .in_layer("roads")
            .at_record(3)
            .at_byte(17);
        assert_eq!(
            e.to_string(),
            "a.gpkg: layer \"roads\": record 3: byte 17: bad blob"
        );
        assert_eq!(FormatError::file("b.shp", "x").to_string(), "b.shp: x");
    }
}
