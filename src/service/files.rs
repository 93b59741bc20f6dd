//! `POST /v1/fit` with a file of [`crate::formats`] as the body, and a GeoPackage as the
//! answer.
//!
//! The body is read within the same byte limit and time budget as GeoJSON (so every limit
//! applies before a byte is parsed); it is then written to a temporary file (a GeoPackage is
//! an SQLite database, read where it lies), read into one FeatureCollection of every layer's
//! features in lon/lat, and fitted like a GeoJSON body; the file is removed when the request
//! ends. A TopoJSON topology sent as `application/json` is decoded the same way.
//!
//! | Content-Type | body |
//! |---|---|
//! | `application/zip` | a zipped Shapefile (`.shp`, `.dbf`, `.prj`, `.cpg`) |
//! | `application/geopackage+sqlite3` | a GeoPackage |
//! | `application/flatgeobuf` | a FlatGeobuf file |
//! | `application/gpx+xml` | a GPX file (tracks fitted in time) |
//!
//! With `Accept: application/geopackage+sqlite3` (listed before any GeoJSON type) the fitted
//! features come back as a GeoPackage (one table, `features`, in EPSG:4326).

use crate::formats::write::FeatureWriter;
use crate::formats::{self, FormatError, Kind, ReadOptions};
use crate::service::error::ApiError;
use axum::http::{header, HeaderMap, StatusCode};
use serde_json::{json, Value};
use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, Ordering};

/// A zipped Shapefile.
pub(crate) const ZIP: &str = "application/zip";
/// A GeoPackage (OGC 12-128r18).
pub(crate) const GEOPACKAGE: &str = "application/geopackage+sqlite3";
/// FlatGeobuf.
pub(crate) const FLATGEOBUF: &str = "application/flatgeobuf";
/// GPX.
pub(crate) const GPX: &str = "application/gpx+xml";

/// The media type of the request's body (its essence, lower case).
fn essence(headers: &HeaderMap, name: header::HeaderName) -> Vec<String> {
    headers
        .get_all(name)
        .iter()
        .filter_map(|v| v.to_str().ok())
        .flat_map(|v| v.split(','))
        .map(|v| {
            v.split(';')
                .next()
                .unwrap_or("")
                .trim()
                .to_ascii_lowercase()
        })
        .collect()
}

/// The file format of the body, from its `Content-Type`.
pub(crate) fn upload_kind(headers: &HeaderMap) -> Option<Kind> {
    match essence(headers, header::CONTENT_TYPE)
        .first()
        .map(String::as_str)
    {
        Some(ZIP) => Some(Kind::Shapefile),
        Some(GEOPACKAGE) => Some(Kind::GeoPackage),
        Some(FLATGEOBUF) => Some(Kind::FlatGeobuf),
        Some(GPX) => Some(Kind::Gpx),
        _ => None,
    }
}

/// True when `Accept` asks for a GeoPackage before any GeoJSON type.
pub(crate) fn wants_geopackage(headers: &HeaderMap) -> bool {
    essence(headers, header::ACCEPT)
        .iter()
        .find(|t| {
            matches!(
                t.as_str(),
                GEOPACKAGE | "application/geo+json" | "application/json" | "*/*"
            )
        })
        .is_some_and(|t| t == GEOPACKAGE)
}

/// A file in the temporary directory, removed when dropped.
struct TempFile(PathBuf);

impl TempFile {
    fn new(ext: &str) -> TempFile {
        static NEXT: AtomicU64 = AtomicU64::new(0);
        let n = NEXT.fetch_add(1, Ordering::Relaxed);
        TempFile(std::env::temp_dir().join(format!("spherefit-{}-{n}.{ext}", std::process::id())))
    }
}

impl Drop for TempFile {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.0);
    }
}

/// A reading error as a problem: 422 `unsupported-crs` for a CRS that cannot be transformed,
/// 400 `unreadable-file` otherwise (a corrupt or truncated file).
fn problem(e: FormatError) -> ApiError {
    if e.reason.contains("the CRS") {
        ApiError::unprocessable("unsupported-crs", e.to_string()).at("")
    } else {
        ApiError::new(StatusCode::BAD_REQUEST, "unreadable-file", e.to_string()).at("")
    }
}

fn internal_io(e: std::io::Error) -> ApiError {
    tracing::error!(error = %e, "temporary file for an upload");
    ApiError::internal()
}

/// The features of a file body as one FeatureCollection.
///
/// # Errors
/// 400 `unreadable-file` (naming the layer, record and byte), 422 `unsupported-crs`.
pub(crate) fn read_upload(bytes: &[u8], kind: Kind) -> Result<Value, ApiError> {
    let ext = match kind {
        Kind::Shapefile => "zip",
        Kind::GeoPackage => "gpkg",
        Kind::FlatGeobuf => "fgb",
        Kind::Gpx => "gpx",
        Kind::TopoJson => "topojson",
    };
    let file = TempFile::new(ext);
    std::fs::write(&file.0, bytes).map_err(internal_io)?;
    let source =
        formats::open(&file.0, "the body", kind, &ReadOptions::default()).map_err(problem)?;
    collect(source.layers)
}

/// Every feature of `layers`, as one FeatureCollection.
fn collect(layers: Vec<formats::Layer>) -> Result<Value, ApiError> {
    let mut features = Vec::new();
    for layer in layers {
        for f in layer.features {
            features.push(f.map_err(problem)?);
        }
    }
    Ok(json!({"type": "FeatureCollection", "features": features}))
}

/// A TopoJSON topology sent as JSON, decoded into a FeatureCollection; other documents as
/// they are.
///
/// # Errors
/// 400 `unreadable-file` for a topology that cannot be decoded.
pub(crate) fn decode_topology(mut value: Value) -> Result<Value, ApiError> {
    if value["type"] != "Topology" {
        return Ok(value);
    }
    let layers = formats::topojson::decode(&mut value, "the body", &ReadOptions::default())
        .map_err(problem)?;
    collect(layers)
}

/// The GeoJSON FeatureCollection `geojson` as a GeoPackage.
///
/// # Errors
/// 500 when the temporary file cannot be written (logged).
pub(crate) fn to_geopackage(geojson: &[u8]) -> Result<Vec<u8>, ApiError> {
    let fc: Value = serde_json::from_slice(geojson).map_err(|e| {
        tracing::error!(error = %e, "fit output is not JSON");
        ApiError::internal()
    })?;
    let out = TempFile::new("gpkg");
    let mut w = FeatureWriter::create(Kind::GeoPackage, &out.0)
        .map_err(internal_io)?
        .with_layer("features");
    for f in fc["features"].as_array().into_iter().flatten() {
        let bytes = serde_json::to_vec(f).map_err(|e| internal_io(e.into()))?;
        w.feature(&bytes).map_err(internal_io)?;
    }
    w.finish().map_err(|e| {
        ApiError::unprocessable(
            "unwritable-output",
            format!("the GeoPackage cannot be written: {e}"),
        )
    })?;
    std::fs::read(&out.0).map_err(internal_io)
}
