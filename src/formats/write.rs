//! Output features written as GeoPackage, FlatGeobuf, Shapefile or GPX, in lon/lat
//! (EPSG:4326, stated in the file).
//!
//! A table's columns must be known before its first row, and are known only once every feature
//! is, so [`FeatureWriter`] spools the features (geometry and flattened properties, one JSON
//! line each) to a temporary file beside the output while it learns the schema, then writes
//! the file from the spool in [`FeatureWriter::finish`]; memory does not grow with the output.
//! Every file is written under a temporary name and renamed into place only when complete.
//!
//! # Columns
//! Each property is a column (numbers, booleans and text with their types; arrays and objects
//! as their JSON text). The fit report (`properties.fit`, or `interpolation`/`evaluation`) is
//! spread into columns the way Python's `spherefit.fit` does ([`REPORT_COLUMNS`]:
//! `max_error_m`, `stored_numbers`, ...), and kept whole as JSON text in a column of its name
//! (the compact curve included) except in a Shapefile, whose text fields hold 254 bytes. A
//! feature `id` is the GeoPackage feature id when the ids are increasing integers, else an `id`
//! column.
//!
//! # Shapefile limits
//! Field names are cut to 10 bytes (the report's columns have short names:
//! [`SHAPEFILE_NAMES`]; any other cut is reported); a text longer than 254 bytes or a number
//! wider than its field is an error naming the feature and field, never a silent cut; a
//! Shapefile holds one kind of geometry (points, lines or polygons).

use crate::formats::dbf;
use crate::formats::dbf::{Column as DbfColumn, ColumnType as DbfType};
use crate::formats::wkb;
use crate::formats::Kind;
use serde_json::{Map, Value};
use std::collections::HashMap;
use std::fs::File;
use std::io::{self, BufRead, BufReader, BufWriter, Write};
use std::path::{Path, PathBuf};

/// The report fields spread into columns, in this order (those a feature has).
pub const REPORT_COLUMNS: [&str; 12] = [
    "max_error_m",
    "mean_error_m",
    "rms_error_m",
    "input_points",
    "control_points",
    "iterations",
    "converged",
    "output_points",
    "sampling_deviation_m",
    "tolerance_met",
    "stored_numbers",
    "compression_ratio",
];

/// The report's column names in a Shapefile (at most 10 bytes).
pub const SHAPEFILE_NAMES: [(&str, &str); 12] = [
    ("max_error_m", "max_err_m"),
    ("mean_error_m", "mean_err_m"),
    ("rms_error_m", "rms_err_m"),
    ("input_points", "in_points"),
    ("control_points", "ctrl_pts"),
    ("iterations", "iterations"),
    ("converged", "converged"),
    ("output_points", "out_points"),
    ("sampling_deviation_m", "samp_dev_m"),
    ("tolerance_met", "tol_met"),
    ("stored_numbers", "stored_num"),
    ("compression_ratio", "compress_r"),
];

/// The property names that hold a report.
const REPORT_KEYS: [&str; 3] = ["fit", "interpolation", "evaluation"];

/// ESRI WKT of lon/lat on WGS 84, as GDAL writes it in a `.prj`.
pub const WGS84_PRJ: &str = r#"GEOGCS["GCS_WGS_1984",DATUM["D_WGS_1984",SPHEROID["WGS_1984",6378137.0,298.257223563]],PRIMEM["Greenwich",0.0],UNIT["Degree",0.0174532925199433]]"#;

/// The type a column has taken so far.
#[derive(Clone, Copy, Debug, PartialEq)]
enum ColType {
    Null,
    Bool,
    Integer,
    Real,
    Text,
}

impl ColType {
    fn of(v: &Value) -> ColType {
        match v {
            Value::Null => ColType::Null,
            Value::Bool(_) => ColType::Bool,
            Value::Number(n) if n.is_i64() || n.is_u64() => ColType::Integer,
            Value::Number(_) => ColType::Real,
            _ => ColType::Text,
        }
    }

    fn merge(self, other: ColType) -> ColType {
        use ColType::*;
        match (self, other) {
            (a, Null) => a,
            (Null, b) => b,
            (a, b) if a == b => a,
            (Integer, Real) | (Real, Integer) => Real,
            _ => Text,
        }
    }
}

/// What [`FeatureWriter`] learned of the features.
#[derive(Default)]
struct Schema {
    names: Vec<String>,
    types: Vec<ColType>,
    index: HashMap<String, usize>,
    /// Widths for a Shapefile: most bytes of a text, most digits of an integer, most digits
    /// before the point of a real.
    widths: Vec<usize>,
    points: bool,
    multipoints: bool,
    lines: bool,
    polygons: bool,
    collections: bool,
    z: bool,
    /// The ids are integers, each larger than the one before.
    ids_increasing: bool,
    last_id: Option<i64>,
    any_id: bool,
}

impl Schema {
    fn column(&mut self, name: &str, v: &Value) {
        let i = match self.index.get(name) {
            Some(&i) => i,
            None => {
                self.names.push(name.to_string());
                self.types.push(ColType::Null);
                self.widths.push(1);
                self.index.insert(name.to_string(), self.names.len() - 1);
                self.names.len() - 1
            }
        };
        self.types[i] = self.types[i].merge(ColType::of(v));
        let w = match v {
            Value::Null => 0,
            Value::String(s) => s.len(),
            Value::Number(n) if n.is_i64() || n.is_u64() => n.to_string().len(),
            Value::Number(n) => {
                let x = n.as_f64().unwrap_or(0.0).abs();
                // Digits before the point, and a sign.
                format!("{:.0}", x.trunc()).len() + 1
            }
            Value::Bool(_) => 1,
            other => other.to_string().len(),
        };
        self.widths[i] = self.widths[i].max(w);
    }

    fn geometry(&mut self, g: &Value) {
        match g["type"].as_str() {
            Some("Point") => self.points = true,
            Some("MultiPoint") => {
                self.points = true;
                self.multipoints = true;
            }
            Some("LineString" | "MultiLineString") => self.lines = true,
            Some("Polygon" | "MultiPolygon") => self.polygons = true,
            Some(_) => self.collections = true,
            None => {}
        }
        self.z |= wkb::has_z(g);
    }
}

/// The properties of an output feature as columns: its own (arrays and objects as JSON text),
/// then the report's fields.
fn flatten(properties: &Map<String, Value>, keep_report_text: bool) -> Vec<(String, Value)> {
    let mut out = Vec::with_capacity(properties.len() + REPORT_COLUMNS.len());
    let mut report = None;
    for (k, v) in properties {
        if REPORT_KEYS.contains(&k.as_str()) && v.is_object() && report.is_none() {
            report = Some((k, v));
            if !keep_report_text {
                continue;
            }
        }
        let v = match v {
            Value::Array(_) | Value::Object(_) => Value::String(v.to_string()),
            other => other.clone(),
        };
        out.push((k.clone(), v));
    }
    if let Some((_, r)) = report {
        for c in REPORT_COLUMNS {
            if let Some(v) = r.get(c) {
                if !properties.contains_key(c) {
                    out.push((c.to_string(), v.clone()));
                }
            }
        }
    }
    out
}

/// Writes output features to a file of one of the formats.
pub struct FeatureWriter {
    kind: Kind,
    target: PathBuf,
    layer: String,
    spool_path: PathBuf,
    spool: Option<BufWriter<File>>,
    schema: Schema,
    count: u64,
    /// Notes for the user (renamed Shapefile fields).
    pub notes: Vec<String>,
}

/// A temporary name beside `path`: `.NAME.spherefit-PID.SUFFIX`.
fn beside(path: &Path, suffix: &str) -> PathBuf {
    let name = path
        .file_name()
        .map_or_else(|| "output".into(), |n| n.to_string_lossy().into_owned());
    path.with_file_name(format!(".{name}.spherefit-{}.{suffix}", std::process::id()))
}

impl FeatureWriter {
    /// A writer of `kind` to `target` (for a Shapefile, the `.shp`; its `.shx`, `.dbf`,
    /// `.prj` and `.cpg` go beside it).
    ///
    /// # Errors
    /// The spool file cannot be created beside the target.
    pub fn create(kind: Kind, target: &Path) -> io::Result<FeatureWriter> {
        if kind == Kind::TopoJson {
            return Err(io::Error::new(
                io::ErrorKind::InvalidInput,
                "TopoJSON is written with --topology shared --output-format topojson",
            ));
        }
        let spool_path = beside(target, "spool");
        let spool = BufWriter::with_capacity(256 << 10, File::create(&spool_path)?);
        let layer = target
            .file_stem()
            .map_or_else(|| "features".into(), |s| s.to_string_lossy().into_owned());
        Ok(FeatureWriter {
            kind,
            target: target.to_path_buf(),
            layer,
            spool_path,
            spool: Some(spool),
            schema: Schema {
                ids_increasing: true,
                ..Schema::default()
            },
            count: 0,
            notes: Vec::new(),
        })
    }

    /// The same writer naming its table (GeoPackage) or layer (FlatGeobuf) `name` instead of
    /// the file's stem.
    pub fn with_layer(mut self, name: &str) -> FeatureWriter {
        self.layer = name.to_string();
        self
    }

    /// Adds one output feature (serialised GeoJSON).
    ///
    /// # Errors
    /// The spool cannot be written, or the bytes are not a Feature.
    pub fn feature(&mut self, json: &[u8]) -> io::Result<()> {
        let f: Value = serde_json::from_slice(json)?;
        let props = f["properties"].as_object().cloned().unwrap_or_default();
        let flat = flatten(&props, self.kind != Kind::Shapefile);
        let id = f.get("id").cloned().unwrap_or(Value::Null);
        if !id.is_null() {
            self.schema.any_id = true;
            match (id.as_i64(), self.schema.last_id) {
                (Some(i), Some(last)) if i > last => self.schema.last_id = Some(i),
                (Some(i), None) => self.schema.last_id = Some(i),
                _ => self.schema.ids_increasing = false,
            }
        } else if self.schema.any_id || self.count > 0 && self.schema.last_id.is_some() {
            self.schema.ids_increasing = false;
        }
        for (k, v) in &flat {
            self.schema.column(k, v);
        }
        self.schema.geometry(&f["geometry"]);
        let line = serde_json::to_vec(&(&f["geometry"], &id, &flat))?;
        let spool = self
            .spool
            .as_mut()
            .ok_or_else(|| io::Error::other("the writer is finished"))?;
        spool.write_all(&line)?;
        spool.write_all(b"\n")?;
        self.count += 1;
        Ok(())
    }

    /// Writes the file from the spool and renames it into place.
    ///
    /// # Errors
    /// A value that does not fit the format (named with its feature and field), or the file
    /// cannot be written. Nothing is left at the target then.
    pub fn finish(mut self) -> Result<Vec<String>, String> {
        if let Some(mut s) = self.spool.take() {
            s.flush()
                .map_err(|e| format!("{}: cannot write: {e}", self.spool_path.display()))?;
        }
        let result = match self.kind {
            Kind::GeoPackage => self.write_gpkg(),
            Kind::FlatGeobuf => self.write_fgb(),
            Kind::Shapefile => self.write_shapefile(),
            Kind::Gpx => self.write_gpx(),
            Kind::TopoJson => Err("TopoJSON is not written here".into()),
        };
        let _ = std::fs::remove_file(&self.spool_path);
        result?;
        Ok(std::mem::take(&mut self.notes))
    }

    /// The spooled features: (geometry, id, columns).
    fn spooled(&self) -> Result<impl Iterator<Item = Result<Spooled, String>>, String> {
        let f = File::open(&self.spool_path).map_err(|e| format!("cannot read the spool: {e}"))?;
        Ok(BufReader::with_capacity(256 << 10, f).lines().map(|l| {
            let l = l.map_err(|e| format!("cannot read the spool: {e}"))?;
            serde_json::from_str::<Spooled>(&l).map_err(|e| format!("the spool is corrupt: {e}"))
        }))
    }

    /// Renames `temp` to `to`, removing `temp` on failure.
    fn commit(temp: &Path, to: &Path) -> Result<(), String> {
        std::fs::rename(temp, to).map_err(|e| {
            let _ = std::fs::remove_file(temp);
            format!("cannot write {}: {e}", to.display())
        })
    }

    fn write_gpkg(&mut self) -> Result<(), String> {
        let temp = beside(&self.target, "gpkg");
        let _ = std::fs::remove_file(&temp);
        let r = self.gpkg_into(&temp);
        match r {
            Ok(()) => Self::commit(&temp, &self.target),
            Err(e) => {
                let _ = std::fs::remove_file(&temp);
                Err(e)
            }
        }
    }

    fn gpkg_into(&self, path: &Path) -> Result<(), String> {
        use super::geopackage::quoted;
        let sql = |e: rusqlite::Error| format!("cannot write the GeoPackage: {e}");
        let mut db = rusqlite::Connection::open(path).map_err(sql)?;
        db.execute_batch(GPKG_SCHEMA).map_err(sql)?;
        let s = &self.schema;
        let fid_is_id = s.any_id && s.ids_increasing;
        let mut cols: Vec<(String, &'static str)> = Vec::new();
        if s.any_id && !fid_is_id && !s.index.contains_key("id") {
            cols.push(("id".into(), "TEXT"));
        }
        for (n, t) in s.names.iter().zip(&s.types) {
            if n.eq_ignore_ascii_case("fid") || n.eq_ignore_ascii_case("geom") {
                return Err(format!(
                    "a property is named {n:?}, the GeoPackage's own column: rename it"
                ));
            }
            cols.push((
                n.clone(),
                match t {
                    ColType::Bool => "BOOLEAN",
                    ColType::Integer => "INTEGER",
                    ColType::Real => "REAL",
                    ColType::Text | ColType::Null => "TEXT",
                },
            ));
        }
        let table = quoted(&self.layer);
        let mut ddl = format!(
            "CREATE TABLE {table} (fid INTEGER PRIMARY KEY AUTOINCREMENT NOT NULL, geom GEOMETRY"
        );
        for (n, t) in &cols {
            ddl.push_str(&format!(", {} {t}", quoted(n)));
        }
        ddl.push(')');
        let tx = db.transaction().map_err(sql)?;
        tx.execute_batch(&ddl).map_err(sql)?;
        // Lines may be LineStrings or MultiLineStrings (and so on): the generic type.
        let geometry_type = "GEOMETRY";
        // gpkg_geometry_columns refers to gpkg_contents: the contents row first, its extent
        // set once the rows are written.
        tx.execute(
            "INSERT INTO gpkg_contents (table_name, data_type, identifier, srs_id) VALUES (?1, 'features', ?1, 4326)",
            rusqlite::params![self.layer],
        )
        .map_err(sql)?;
        tx.execute(
            "INSERT INTO gpkg_geometry_columns (table_name, column_name, geometry_type_name, srs_id, z, m) VALUES (?1, 'geom', ?2, 4326, ?3, 0)",
            rusqlite::params![self.layer, geometry_type, i32::from(s.z)],
        )
        .map_err(sql)?;
        let placeholders: Vec<String> =
            (0..cols.len() + 2).map(|i| format!("?{}", i + 1)).collect();
        let names: Vec<String> = std::iter::once("fid".to_string())
            .chain(std::iter::once("geom".to_string()))
            .chain(cols.iter().map(|(n, _)| quoted(n)))
            .collect();
        let insert = format!(
            "INSERT INTO {table} ({}) VALUES ({})",
            names.join(", "),
            placeholders.join(", ")
        );
        let mut bbox: Option<[f64; 4]> = None;
        {
            let mut stmt = tx.prepare(&insert).map_err(sql)?;
            let id_col = usize::from(s.any_id && !fid_is_id && !s.index.contains_key("id"));
            for (n, row) in self.spooled()?.enumerate() {
                let (geometry, id, flat) = row?;
                let mut values: Vec<rusqlite::types::Value> =
                    vec![rusqlite::types::Value::Null; cols.len() + 2];
                if fid_is_id {
                    values[0] =
                        rusqlite::types::Value::Integer(id.as_i64().unwrap_or(n as i64 + 1));
                }
                if !geometry.is_null() {
                    let mut blob = gpkg_header(&geometry);
                    wkb::write(&geometry, &mut blob)
                        .map_err(|e| format!("feature {}: {e}", n + 1))?;
                    if let Some(e) = wkb::envelope(&geometry) {
                        let b = bbox.get_or_insert(e);
                        *b = [
                            b[0].min(e[0]),
                            b[1].max(e[1]),
                            b[2].min(e[2]),
                            b[3].max(e[3]),
                        ];
                    }
                    values[1] = rusqlite::types::Value::Blob(blob);
                }
                if id_col == 1 && !id.is_null() {
                    values[2] = rusqlite::types::Value::Text(match &id {
                        Value::String(s) => s.clone(),
                        other => other.to_string(),
                    });
                }
                for (k, v) in flat {
                    if let Some(&i) = s.index.get(&k) {
                        values[2 + id_col + i] = sql_value(&v, s.types[i]);
                    }
                }
                stmt.execute(rusqlite::params_from_iter(values))
                    .map_err(sql)?;
            }
        }
        let b = bbox.unwrap_or([0.0; 4]);
        tx.execute(
            "UPDATE gpkg_contents SET min_x = ?2, min_y = ?3, max_x = ?4, max_y = ?5 WHERE table_name = ?1",
            rusqlite::params![self.layer, b[0], b[2], b[1], b[3]],
        )
        .map_err(sql)?;
        tx.commit().map_err(sql)?;
        db.close().map_err(|(_, e)| sql(e))
    }

    fn write_fgb(&mut self) -> Result<(), String> {
        use flatgeobuf::geozero::{ColumnValue, PropertyProcessor};
        use flatgeobuf::{ColumnType, FgbCrs, FgbWriter, FgbWriterOptions, GeometryType};
        let s = &self.schema;
        // Mixed kinds are allowed in one file: the header says Unknown, each feature its own.
        let kind = GeometryType::Unknown;
        let options = FgbWriterOptions {
            write_index: false,
            detect_type: false,
            promote_to_multi: false,
            has_z: s.z,
            crs: FgbCrs {
                code: 4326,
                ..FgbCrs::default()
            },
            ..FgbWriterOptions::default()
        };
        let mut fgb = FgbWriter::create_with_options(&self.layer, kind, options)
            .map_err(|e| format!("cannot write the FlatGeobuf: {e}"))?;
        let id_col = s.any_id && !s.index.contains_key("id");
        let mut names: Vec<(String, ColType)> = Vec::new();
        if id_col {
            names.push(("id".into(), ColType::Text));
        }
        names.extend(s.names.iter().cloned().zip(s.types.iter().copied()));
        for (n, t) in &names {
            let ct = match t {
                ColType::Bool => ColumnType::Bool,
                ColType::Integer => ColumnType::Long,
                ColType::Real => ColumnType::Double,
                ColType::Text | ColType::Null => ColumnType::String,
            };
            fgb.add_column(n, ct, |_, c| c.nullable = true);
        }
        for (n, row) in self.spooled()?.enumerate() {
            let (geometry, id, flat) = row?;
            let mut values: Vec<Value> = vec![Value::Null; names.len()];
            if id_col {
                values[0] = match id {
                    Value::Null => Value::Null,
                    Value::String(s) => Value::String(s),
                    other => Value::String(other.to_string()),
                };
            }
            for (k, v) in flat {
                if let Some(&i) = s.index.get(&k) {
                    values[usize::from(id_col) + i] = v;
                }
            }
            let text = if geometry.is_null() {
                // FlatGeobuf needs a geometry: an empty collection stands for none.
                r#"{"type":"GeometryCollection","geometries":[]}"#.to_string()
            } else {
                geometry.to_string()
            };
            let mut failed = None;
            fgb.add_feature_geom(flatgeobuf::geozero::geojson::GeoJson(&text), |feat| {
                for (i, ((name, t), v)) in names.iter().zip(&values).enumerate() {
                    let text_value;
                    let cv = match (t, v) {
                        (_, Value::Null) => continue,
                        (ColType::Bool, Value::Bool(b)) => ColumnValue::Bool(*b),
                        (ColType::Integer, Value::Number(x)) => {
                            ColumnValue::Long(x.as_i64().unwrap_or(0))
                        }
                        (ColType::Real, Value::Number(x)) => {
                            ColumnValue::Double(x.as_f64().unwrap_or(f64::NAN))
                        }
                        (_, Value::String(s)) => ColumnValue::String(s),
                        (_, other) => {
                            text_value = other.to_string();
                            ColumnValue::String(&text_value)
                        }
                    };
                    if let Err(e) = feat.property(i, name, &cv) {
                        failed = Some(format!("feature {}: column {name:?}: {e}", n + 1));
                    }
                }
            })
            .map_err(|e| format!("feature {}: {e}", n + 1))?;
            if let Some(e) = failed {
                return Err(e);
            }
        }
        let temp = beside(&self.target, "fgb");
        let out = File::create(&temp).map_err(|e| format!("cannot create: {e}"))?;
        let written = fgb
            .write(BufWriter::new(out))
            .map_err(|e| format!("cannot write the FlatGeobuf: {e}"));
        match written {
            Ok(()) => Self::commit(&temp, &self.target),
            Err(e) => {
                let _ = std::fs::remove_file(&temp);
                Err(e)
            }
        }
    }

    fn write_shapefile(&mut self) -> Result<(), String> {
        let s = &self.schema;
        let shape_type = match (s.points, s.lines, s.polygons, s.collections) {
            (_, _, _, true) => {
                return Err("a Shapefile cannot hold a GeometryCollection: write GeoPackage (.gpkg) or FlatGeobuf (.fgb)".into())
            }
            (true, false, false, _) if !s.multipoints => 1,
            (true, false, false, _) => 8,
            (false, true, false, _) => 3,
            (false, false, true, _) | (false, false, false, _) => 5,
            _ => {
                return Err("a Shapefile holds one kind of geometry (points, lines or polygons) and these features mix them: write GeoPackage (.gpkg) or FlatGeobuf (.fgb)".into())
            }
        };
        let shape_type = if s.z { shape_type + 10 } else { shape_type };
        // Columns: names cut to 10 bytes, each once.
        let mut columns = Vec::new();
        let mut used: Vec<String> = Vec::new();
        let id_col = s.any_id && !s.index.contains_key("id");
        let mut sources: Vec<(Option<usize>, ColType, usize)> = Vec::new();
        if id_col {
            sources.push((None, ColType::Text, 1));
        }
        for (i, n) in s.names.iter().enumerate() {
            sources.push((Some(i), s.types[i], s.widths[i]));
            let _ = n;
        }
        for (src, t, width) in &sources {
            let full = src.map_or("id".to_string(), |i| s.names[i].clone());
            let mut short = SHAPEFILE_NAMES
                .iter()
                .find(|(l, _)| *l == full)
                .map_or_else(|| cut(&full, 10), |(_, s)| s.to_string());
            let mut k = 1;
            while used.iter().any(|u| u.eq_ignore_ascii_case(&short)) {
                let suffix = format!("_{k}");
                short = format!("{}{suffix}", cut(&full, 10 - suffix.len()));
                k += 1;
            }
            if short != full && !SHAPEFILE_NAMES.iter().any(|(l, _)| *l == full) {
                self.notes.push(format!("the property {full:?} is the field {short:?} (Shapefile field names have at most 10 bytes)"));
            }
            used.push(short.clone());
            let (kind, length, decimals) = match t {
                ColType::Bool => (DbfType::Boolean, 1, 0),
                ColType::Integer => (DbfType::Integer, (*width).clamp(1, 20), 0),
                ColType::Real => {
                    let int_digits = (*width).max(2);
                    if int_digits + 1 > dbf::REAL_WIDTH {
                        (DbfType::Real, dbf::REAL_WIDTH, 0)
                    } else {
                        (
                            DbfType::Real,
                            dbf::REAL_WIDTH,
                            dbf::REAL_DECIMALS.min(dbf::REAL_WIDTH - int_digits - 1),
                        )
                    }
                }
                ColType::Text | ColType::Null => {
                    (DbfType::Text, (*width).clamp(1, dbf::MAX_TEXT), 0)
                }
            };
            columns.push(DbfColumn {
                name: short,
                kind,
                length,
                decimals,
            });
        }
        let paths: Vec<(PathBuf, PathBuf)> = ["shp", "shx", "dbf", "prj", "cpg"]
            .iter()
            .map(|ext| {
                let final_path = self.target.with_extension(ext);
                (beside(&final_path, ext), final_path)
            })
            .collect();
        let result = self.shapefile_into(&paths, shape_type, &columns, &sources);
        match result {
            Ok(()) => {
                for (temp, to) in &paths {
                    Self::commit(temp, to)?;
                }
                Ok(())
            }
            Err(e) => {
                for (temp, _) in &paths {
                    let _ = std::fs::remove_file(temp);
                }
                Err(e)
            }
        }
    }

    fn shapefile_into(
        &self,
        paths: &[(PathBuf, PathBuf)],
        shape_type: i32,
        columns: &[DbfColumn],
        sources: &[(Option<usize>, ColType, usize)],
    ) -> Result<(), String> {
        let io = |e: io::Error| format!("cannot write: {e}");
        let create = |p: &Path| {
            File::create(p)
                .map(|f| BufWriter::with_capacity(256 << 10, f))
                .map_err(io)
        };
        let mut shp = create(&paths[0].0)?;
        let mut shx = create(&paths[1].0)?;
        let mut dbf_out = create(&paths[2].0)?;
        std::fs::write(&paths[3].0, WGS84_PRJ).map_err(io)?;
        std::fs::write(&paths[4].0, "UTF-8").map_err(io)?;
        let records = u32::try_from(self.count)
            .map_err(|_| "too many features for a Shapefile".to_string())?;
        dbf::write_header(&mut dbf_out, columns, records).map_err(io)?;
        // The .shp and .shx headers need the extent and length: written as placeholders and
        // rewritten at the end.
        shp.write_all(&[0u8; 100]).map_err(io)?;
        shx.write_all(&[0u8; 100]).map_err(io)?;
        let mut offset_words = 50u32;
        let mut bbox: Option<[f64; 4]> = None;
        let mut zrange: Option<[f64; 2]> = None;
        let s = &self.schema;
        for (n, row) in self.spooled()?.enumerate() {
            let (geometry, id, flat) = row?;
            let content = shp_content(&geometry, shape_type, &mut bbox, &mut zrange)
                .map_err(|e| format!("feature {}: {e}", n + 1))?;
            let words = u32::try_from(content.len() / 2)
                .map_err(|_| format!("feature {}: too large for a Shapefile", n + 1))?;
            shp.write_all(&(n as u32 + 1).to_be_bytes()).map_err(io)?;
            shp.write_all(&words.to_be_bytes()).map_err(io)?;
            shp.write_all(&content).map_err(io)?;
            shx.write_all(&offset_words.to_be_bytes()).map_err(io)?;
            shx.write_all(&words.to_be_bytes()).map_err(io)?;
            offset_words = offset_words
                .checked_add(4 + words)
                .filter(|w| *w < i32::MAX as u32)
                .ok_or_else(|| {
                    "the .shp would exceed 4 GB, the format's limit: write GeoPackage (.gpkg)"
                        .to_string()
                })?;
            let values: HashMap<String, Value> = flat.into_iter().collect();
            dbf_out.write_all(b" ").map_err(io)?;
            for (c, (src, _, _)) in columns.iter().zip(sources) {
                let v = match src {
                    None => match &id {
                        Value::Null => Value::Null,
                        Value::String(s) => Value::String(s.clone()),
                        other => Value::String(other.to_string()),
                    },
                    Some(i) => values.get(&s.names[*i]).cloned().unwrap_or(Value::Null),
                };
                let bytes = dbf::encode(c, &v).map_err(|e| {
                    let name = src.map_or("id", |i| s.names[i].as_str());
                    format!("feature {}: property {name:?}: {e}", n + 1)
                })?;
                dbf_out.write_all(&bytes).map_err(io)?;
            }
        }
        dbf_out.write_all(&[0x1a]).map_err(io)?;
        let b = bbox.unwrap_or([0.0; 4]);
        let z = zrange.unwrap_or([0.0; 2]);
        for (w, len_words) in [(&mut shp, offset_words), (&mut shx, 50 + 4 * records)] {
            w.flush().map_err(io)?;
            let f = w.get_mut();
            use std::io::{Seek, SeekFrom};
            f.seek(SeekFrom::Start(0)).map_err(io)?;
            f.write_all(&shp_header(len_words, shape_type, b, z))
                .map_err(io)?;
            f.flush().map_err(io)?;
        }
        dbf_out.flush().map_err(io)?;
        Ok(())
    }

    fn write_gpx(&mut self) -> Result<(), String> {
        let temp = beside(&self.target, "gpx");
        let r = self.gpx_into(&temp);
        match r {
            Ok(()) => Self::commit(&temp, &self.target),
            Err(e) => {
                let _ = std::fs::remove_file(&temp);
                Err(e)
            }
        }
    }

    fn gpx_into(&self, path: &Path) -> Result<(), String> {
        let io = |e: io::Error| format!("cannot write: {e}");
        let mut out = BufWriter::new(File::create(path).map_err(io)?);
        out.write_all(b"<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<gpx version=\"1.1\" creator=\"spherefit\" xmlns=\"http://www.topografix.com/GPX/1/1\">\n").map_err(io)?;
        let mut waypoints = Vec::new();
        let mut tracks = Vec::new();
        for (n, row) in self.spooled()?.enumerate() {
            let (geometry, _, flat) = row?;
            let props: Map<String, Value> = flat.into_iter().collect();
            match geometry["type"].as_str() {
                Some("Point") => waypoints.push(gpx_point("wpt", &geometry["coordinates"], props.get("time"), Some(&props))),
                Some("MultiPoint") => {
                    for p in geometry["coordinates"].as_array().into_iter().flatten() {
                        waypoints.push(gpx_point("wpt", p, None, Some(&props)));
                    }
                }
                Some("LineString" | "MultiLineString") => {
                    tracks.push(gpx_track(&geometry, &props).map_err(|e| format!("feature {}: {e}", n + 1))?)
                }
                // No geometry: an empty track keeps the feature (and its name).
                None => tracks.push(gpx_track(
                    &serde_json::json!({"type": "MultiLineString", "coordinates": []}),
                    &props,
                )?),
                Some(other) => {
                    return Err(format!(
                        "feature {}: a {other} has no GPX form (GPX holds waypoints and tracks): write GeoPackage (.gpkg)",
                        n + 1
                    ))
                }
            }
        }
        for w in waypoints.iter().chain(&tracks) {
            out.write_all(w.as_bytes()).map_err(io)?;
        }
        out.write_all(b"</gpx>\n").map_err(io)?;
        out.flush().map_err(io)
    }
}

impl Drop for FeatureWriter {
    fn drop(&mut self) {
        // A writer dropped unfinished (the run failed) leaves nothing behind.
        drop(self.spool.take());
        let _ = std::fs::remove_file(&self.spool_path);
    }
}

/// (geometry, id, columns) of a spooled feature.
type Spooled = (Value, Value, Vec<(String, Value)>);

/// The first `n` bytes of `s`, cut at a character boundary.
fn cut(s: &str, n: usize) -> String {
    let mut end = n.min(s.len());
    while !s.is_char_boundary(end) {
        end -= 1;
    }
    s[..end].to_string()
}

fn sql_value(v: &Value, t: ColType) -> rusqlite::types::Value {
    use rusqlite::types::Value as S;
    match (v, t) {
        (Value::Null, _) => S::Null,
        (Value::Bool(b), ColType::Bool) => S::Integer(i64::from(*b)),
        (Value::Number(n), ColType::Integer) => n
            .as_i64()
            .map_or(S::Real(n.as_f64().unwrap_or(f64::NAN)), S::Integer),
        (Value::Number(n), ColType::Real) => S::Real(n.as_f64().unwrap_or(f64::NAN)),
        (Value::String(s), _) => S::Text(s.clone()),
        (other, _) => S::Text(other.to_string()),
    }
}

/// A GeoPackage geometry header (little-endian, with an x/y envelope) for srs 4326.
fn gpkg_header(g: &Value) -> Vec<u8> {
    let mut b = b"GP\x00".to_vec();
    match wkb::envelope(g) {
        Some(e) => {
            b.push(0b0000_0011);
            b.extend_from_slice(&4326i32.to_le_bytes());
            for v in e {
                b.extend_from_slice(&v.to_le_bytes());
            }
        }
        None => {
            b.push(0b0001_0001);
            b.extend_from_slice(&4326i32.to_le_bytes());
        }
    }
    b
}

/// The tables of an empty GeoPackage 1.3 with EPSG:4326 and the two undefined systems.
const GPKG_SCHEMA: &str = r#"
PRAGMA application_id = 1196444487;
PRAGMA user_version = 10300;
CREATE TABLE gpkg_spatial_ref_sys (srs_name TEXT NOT NULL, srs_id INTEGER PRIMARY KEY, organization TEXT NOT NULL, organization_coordsys_id INTEGER NOT NULL, definition TEXT NOT NULL, description TEXT);
CREATE TABLE gpkg_contents (table_name TEXT NOT NULL PRIMARY KEY, data_type TEXT NOT NULL, identifier TEXT UNIQUE, description TEXT DEFAULT '', last_change DATETIME NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ','now')), min_x DOUBLE, min_y DOUBLE, max_x DOUBLE, max_y DOUBLE, srs_id INTEGER, CONSTRAINT fk_gc_r_srs_id FOREIGN KEY (srs_id) REFERENCES gpkg_spatial_ref_sys(srs_id));
CREATE TABLE gpkg_geometry_columns (table_name TEXT NOT NULL, column_name TEXT NOT NULL, geometry_type_name TEXT NOT NULL, srs_id INTEGER NOT NULL, z TINYINT NOT NULL, m TINYINT NOT NULL, CONSTRAINT pk_geom_cols PRIMARY KEY (table_name, column_name), CONSTRAINT fk_gc_tn FOREIGN KEY (table_name) REFERENCES gpkg_contents(table_name), CONSTRAINT fk_gc_srs FOREIGN KEY (srs_id) REFERENCES gpkg_spatial_ref_sys (srs_id));
INSERT INTO gpkg_spatial_ref_sys VALUES ('Undefined cartesian SRS', -1, 'NONE', -1, 'undefined', 'undefined cartesian coordinate reference system');
INSERT INTO gpkg_spatial_ref_sys VALUES ('Undefined geographic SRS', 0, 'NONE', 0, 'undefined', 'undefined geographic coordinate reference system');
INSERT INTO gpkg_spatial_ref_sys VALUES ('WGS 84 geodetic', 4326, 'EPSG', 4326, 'GEOGCS["WGS 84",DATUM["WGS_1984",SPHEROID["WGS 84",6378137,298.257223563,AUTHORITY["EPSG","7030"]],AUTHORITY["EPSG","6326"]],PRIMEM["Greenwich",0,AUTHORITY["EPSG","8901"]],UNIT["degree",0.0174532925199433,AUTHORITY["EPSG","9122"]],AXIS["Latitude",NORTH],AXIS["Longitude",EAST],AUTHORITY["EPSG","4326"]]', 'longitude/latitude coordinates in decimal degrees on the WGS 84 spheroid');
"#;

/// A `.shp` / `.shx` header.
fn shp_header(length_words: u32, shape_type: i32, b: [f64; 4], z: [f64; 2]) -> [u8; 100] {
    let mut h = [0u8; 100];
    h[..4].copy_from_slice(&9994i32.to_be_bytes());
    h[24..28].copy_from_slice(&length_words.to_be_bytes());
    h[28..32].copy_from_slice(&1000i32.to_le_bytes());
    h[32..36].copy_from_slice(&shape_type.to_le_bytes());
    for (i, v) in [b[0], b[2], b[1], b[3], z[0], z[1], 0.0, 0.0]
        .iter()
        .enumerate()
    {
        h[36 + 8 * i..44 + 8 * i].copy_from_slice(&v.to_le_bytes());
    }
    h
}

/// The positions of a GeoJSON position list as (x, y, z).
fn positions(v: &Value) -> Vec<(f64, f64, f64)> {
    v.as_array()
        .into_iter()
        .flatten()
        .map(|p| {
            let n = |i: usize| p.get(i).and_then(Value::as_f64);
            (
                n(0).unwrap_or(f64::NAN),
                n(1).unwrap_or(f64::NAN),
                n(2).unwrap_or(0.0),
            )
        })
        .collect()
}

/// Twice the signed planar area of a ring (positive counter-clockwise).
fn area2(r: &[(f64, f64, f64)]) -> f64 {
    (0..r.len())
        .map(|i| {
            let (a, b) = (r[i], r[(i + 1) % r.len()]);
            a.0 * b.1 - b.0 * a.1
        })
        .sum()
}

/// A record's content (shape type, box, parts, points, and Z for the Z types).
fn shp_content(
    g: &Value,
    shape_type: i32,
    bbox: &mut Option<[f64; 4]>,
    zrange: &mut Option<[f64; 2]>,
) -> Result<Vec<u8>, String> {
    let mut out = Vec::new();
    if g.is_null() {
        out.extend_from_slice(&0i32.to_le_bytes());
        return Ok(out);
    }
    let c = &g["coordinates"];
    let parts: Vec<Vec<(f64, f64, f64)>> = match g["type"].as_str() {
        Some("Point") => vec![positions(&Value::Array(vec![c.clone()]))],
        Some("MultiPoint") => vec![positions(c)],
        Some("LineString") => vec![positions(c)],
        Some("MultiLineString") => c.as_array().into_iter().flatten().map(positions).collect(),
        Some("Polygon" | "MultiPolygon") => {
            let polys: Vec<&Value> = if g["type"] == "Polygon" {
                vec![c]
            } else {
                c.as_array().into_iter().flatten().collect()
            };
            let mut rings = Vec::new();
            for p in polys {
                for (k, r) in p.as_array().into_iter().flatten().enumerate() {
                    let mut ring = positions(r);
                    // Outer rings clockwise, holes counter-clockwise, as the format defines.
                    let clockwise = area2(&ring) < 0.0;
                    if (k == 0) != clockwise {
                        ring.reverse();
                    }
                    rings.push(ring);
                }
            }
            rings
        }
        other => return Err(format!("a {other:?} cannot be written in a Shapefile")),
    };
    let all: Vec<(f64, f64, f64)> = parts.iter().flatten().copied().collect();
    let (base, z) = (shape_type % 10, shape_type > 10);
    out.extend_from_slice(&shape_type.to_le_bytes());
    let mut b = [
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    ];
    let mut zr = [f64::INFINITY, f64::NEG_INFINITY];
    for p in &all {
        b = [b[0].min(p.0), b[1].max(p.0), b[2].min(p.1), b[3].max(p.1)];
        zr = [zr[0].min(p.2), zr[1].max(p.2)];
    }
    if !all.is_empty() {
        let fb = bbox.get_or_insert(b);
        *fb = [
            fb[0].min(b[0]),
            fb[1].max(b[1]),
            fb[2].min(b[2]),
            fb[3].max(b[3]),
        ];
        let fz = zrange.get_or_insert(zr);
        *fz = [fz[0].min(zr[0]), fz[1].max(zr[1])];
    }
    if base == 1 {
        let p = all.first().copied().unwrap_or((f64::NAN, f64::NAN, 0.0));
        out.extend_from_slice(&p.0.to_le_bytes());
        out.extend_from_slice(&p.1.to_le_bytes());
        if z {
            out.extend_from_slice(&p.2.to_le_bytes());
            out.extend_from_slice(&0f64.to_le_bytes());
        }
        return Ok(out);
    }
    for v in [b[0], b[2], b[1], b[3]] {
        out.extend_from_slice(&v.to_le_bytes());
    }
    if base != 8 {
        out.extend_from_slice(&(parts.len() as i32).to_le_bytes());
    }
    out.extend_from_slice(&(all.len() as i32).to_le_bytes());
    if base != 8 {
        let mut start = 0i32;
        for p in &parts {
            out.extend_from_slice(&start.to_le_bytes());
            start += p.len() as i32;
        }
    }
    for p in &all {
        out.extend_from_slice(&p.0.to_le_bytes());
        out.extend_from_slice(&p.1.to_le_bytes());
    }
    if z {
        out.extend_from_slice(&zr[0].to_le_bytes());
        out.extend_from_slice(&zr[1].to_le_bytes());
        for p in &all {
            out.extend_from_slice(&p.2.to_le_bytes());
        }
    }
    Ok(out)
}

/// Escapes text for XML.
fn xml(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// A `<wpt>` or `<trkpt>` element.
fn gpx_point(
    tag: &str,
    p: &Value,
    time: Option<&Value>,
    props: Option<&Map<String, Value>>,
) -> String {
    let n = |i: usize| p.get(i).and_then(Value::as_f64);
    let mut s = format!(
        "<{tag} lat=\"{}\" lon=\"{}\">",
        n(1).unwrap_or(f64::NAN),
        n(0).unwrap_or(f64::NAN)
    );
    if let Some(z) = n(2) {
        s.push_str(&format!("<ele>{z}</ele>"));
    }
    // Unix seconds are written as RFC 3339, as GPX wants.
    let time = time.map(|t| match t.as_f64() {
        Some(unix_s) => crate::earth::TimeFormat::Rfc3339.write(unix_s),
        None => t.clone(),
    });
    if let Some(t) = time.as_ref().and_then(Value::as_str) {
        s.push_str(&format!("<time>{}</time>", xml(t)));
    }
    if let Some(props) = props {
        for k in ["name", "cmt", "desc", "src", "sym", "type"] {
            if let Some(v) = props.get(k).and_then(Value::as_str) {
                s.push_str(&format!("<{k}>{}</{k}>", xml(v)));
            }
        }
    }
    s.push_str(&format!("</{tag}>\n"));
    s
}

/// A `<trk>` of a (Multi)LineString, with each point's time from `coordTimes` when the output
/// has them.
fn gpx_track(g: &Value, props: &Map<String, Value>) -> Result<String, String> {
    let lines: Vec<&Value> = if g["type"] == "LineString" {
        vec![&g["coordinates"]]
    } else {
        g["coordinates"].as_array().into_iter().flatten().collect()
    };
    let times: Option<Value> = props
        .get("coordTimes")
        .and_then(Value::as_str)
        .and_then(|t| serde_json::from_str(t).ok());
    let mut s = String::from("<trk>");
    for k in ["name", "cmt", "desc", "src", "type"] {
        if let Some(v) = props.get(k).and_then(Value::as_str) {
            s.push_str(&format!("<{k}>{}</{k}>", xml(v)));
        }
    }
    s.push('\n');
    for (li, line) in lines.iter().enumerate() {
        let line_times = times.as_ref().map(|t| {
            if lines.len() > 1 || t.get(0).is_some_and(Value::is_array) {
                t[li].clone()
            } else {
                t.clone()
            }
        });
        let pts = line.as_array().map(Vec::as_slice).unwrap_or_default();
        if let Some(t) = &line_times {
            if t.as_array().map_or(0, Vec::len) != pts.len() {
                return Err("its coordTimes do not match its positions one to one".into());
            }
        }
        s.push_str("<trkseg>\n");
        for (i, p) in pts.iter().enumerate() {
            let t = line_times.as_ref().map(|t| &t[i]);
            s.push_str(&gpx_point("trkpt", p, t, None));
        }
        s.push_str("</trkseg>\n");
    }
    s.push_str("</trk>\n");
    Ok(s)
}
