//! OGC GeoPackage (an SQLite database, read with rusqlite's bundled SQLite): every feature
//! table of `gpkg_contents` in its order, or the one named.
//!
//! A table's rows are fetched in pages of [`PAGE_ROWS`] in feature-id order (`WHERE fid > ?
//! ORDER BY fid LIMIT n`), so a large file is never loaded whole. The feature id is the GeoJSON
//! `id`; the other columns are `properties` (INTEGER, REAL, TEXT as JSON numbers and strings,
//! BOOLEAN as `true`/`false`, DATE and DATETIME as their text, BLOB as base64). The geometry
//! blob (`GP` header and WKB) is read by the `wkb` module; its CRS is the table's `srs_id` in
//! `gpkg_spatial_ref_sys` (0 is "undefined geographic": lon/lat, as the specification says).

use crate::formats::crs::Crs;
use crate::formats::wkb;
use crate::formats::{feature, FeatureResult, FormatError, Layer, ReadOptions};
use base64::Engine;
use rusqlite::types::ValueRef;
use rusqlite::{Connection, OpenFlags};
use serde_json::{Map, Value};
use std::collections::VecDeque;
use std::path::Path;

/// Rows fetched per query.
pub const PAGE_ROWS: usize = 1000;

fn db_error(name: &str, e: impl std::fmt::Display) -> FormatError {
    FormatError::file(name, format!("not a readable GeoPackage: {e}"))
}

/// A name quoted for SQL.
pub fn quoted(name: &str) -> String {
    format!("\"{}\"", name.replace('"', "\"\""))
}

fn connect(path: &Path, name: &str) -> Result<Connection, FormatError> {
    Connection::open_with_flags(
        path,
        OpenFlags::SQLITE_OPEN_READ_ONLY | OpenFlags::SQLITE_OPEN_NO_MUTEX,
    )
    .map_err(|e| db_error(name, e))
}

/// Opens the feature tables of a GeoPackage.
pub fn open(path: &Path, name: &str, options: &ReadOptions) -> Result<Vec<Layer>, FormatError> {
    let db = connect(path, name)?;
    let tables: Vec<String> = db
        .prepare("SELECT table_name FROM gpkg_contents WHERE data_type = 'features' ORDER BY rowid")
        .and_then(|mut s| {
            s.query_map([], |r| r.get::<_, String>(0))?
                .collect::<Result<Vec<_>, _>>()
        })
        .map_err(|e| db_error(name, format!("{e} (no gpkg_contents table of features)")))?;
    let tables = match &options.layer {
        Some(l) => {
            if !tables.contains(l) {
                return Err(FormatError::file(
                    name,
                    format!("--layer {l:?}: no feature table of that name (it has {tables:?})"),
                ));
            }
            vec![l.clone()]
        }
        None => tables,
    };
    if tables.is_empty() {
        return Err(FormatError::file(
            name,
            "the GeoPackage has no feature tables",
        ));
    }
    tables
        .into_iter()
        .map(|t| table(path, name, &db, t))
        .collect()
}

/// A column of a table: its name and declared type (upper case).
#[derive(Clone, Debug)]
struct Column {
    name: String,
    kind: String,
}

fn table(path: &Path, name: &str, db: &Connection, t: String) -> Result<Layer, FormatError> {
    let fail = |e: String| FormatError::file(name, e).in_layer(&t);
    let (geom_col, srs_id): (String, i64) = db
        .query_row(
            "SELECT column_name, srs_id FROM gpkg_geometry_columns WHERE table_name = ?1",
            [&t],
            |r| Ok((r.get(0)?, r.get(1)?)),
        )
        .map_err(|e| fail(format!("no row in gpkg_geometry_columns: {e}")))?;
    let crs = srs(db, srs_id).map_err(fail)?;
    let mut columns = Vec::new();
    let mut fid = None;
    let mut s = db
        .prepare(&format!("PRAGMA table_info({})", quoted(&t)))
        .map_err(|e| fail(e.to_string()))?;
    let rows = s
        .query_map([], |r| {
            Ok((
                r.get::<_, String>(1)?,
                r.get::<_, Option<String>>(2)?.unwrap_or_default(),
                r.get::<_, i64>(5)?,
            ))
        })
        .and_then(|rows| rows.collect::<Result<Vec<_>, _>>())
        .map_err(|e| fail(e.to_string()))?;
    for (col, kind, pk) in rows {
        let kind = kind.to_ascii_uppercase();
        if pk == 1 && kind == "INTEGER" {
            fid = Some(col);
        } else if col != geom_col {
            columns.push(Column { name: col, kind });
        }
    }
    let fid =
        fid.ok_or_else(|| fail("the table has no INTEGER PRIMARY KEY (feature id)".into()))?;
    let list: Vec<String> = std::iter::once(quoted(&fid))
        .chain(std::iter::once(quoted(&geom_col)))
        .chain(columns.iter().map(|c| quoted(&c.name)))
        .collect();
    let sql = format!(
        "SELECT {} FROM {} WHERE {} > ?1 ORDER BY {} LIMIT {PAGE_ROWS}",
        list.join(", "),
        quoted(&t),
        quoted(&fid),
        quoted(&fid)
    );
    let rows = Rows {
        db: connect(path, name)?,
        file: name.to_string(),
        layer: t.clone(),
        sql,
        columns,
        crs: crs.clone(),
        srs_id,
        after: i64::MIN,
        page: VecDeque::new(),
        number: 0,
        done: false,
    };
    Ok(Layer {
        name: t,
        crs,
        features: Box::new(rows),
    })
}

/// The CRS of `srs_id`.
fn srs(db: &Connection, srs_id: i64) -> Result<Crs, String> {
    match srs_id {
        0 => return Ok(Crs::lonlat("undefined geographic (srs_id 0)")),
        -1 => {
            return Err(
                "the CRS is \"undefined Cartesian\" (srs_id -1): its coordinates cannot be placed on the Earth"
                    .into(),
            )
        }
        _ => {}
    }
    let (org, code, def): (String, i64, String) = db
        .query_row(
            "SELECT organization, organization_coordsys_id, definition FROM gpkg_spatial_ref_sys WHERE srs_id = ?1",
            [srs_id],
            |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?)),
        )
        .map_err(|e| format!("srs_id {srs_id} is not in gpkg_spatial_ref_sys: {e}"))?;
    if org.eq_ignore_ascii_case("EPSG") {
        return Crs::from_epsg(code);
    }
    Crs::from_wkt(&def).map_err(|e| format!("srs_id {srs_id} ({org}:{code}): {e}"))
}

/// The rows of one table, a page at a time.
struct Rows {
    db: Connection,
    file: String,
    layer: String,
    sql: String,
    columns: Vec<Column>,
    crs: Crs,
    srs_id: i64,
    /// The last feature id read.
    after: i64,
    page: VecDeque<FeatureResult>,
    number: u64,
    done: bool,
}

impl Rows {
    fn fail(&self, record: u64, why: String) -> FormatError {
        FormatError::file(&self.file, why)
            .in_layer(&self.layer)
            .at_record(record)
    }

    /// Fetches the next page into `page`.
    fn fetch(&mut self) -> Result<(), FormatError> {
        let number = self.number;
        let mut stmt = self
            .db
            .prepare_cached(&self.sql)
            .map_err(|e| self.fail(number + 1, e.to_string()))?;
        let mut rows = stmt
            .query([self.after])
            .map_err(|e| FormatError::file(&self.file, e.to_string()).in_layer(&self.layer))?;
        let mut out = VecDeque::new();
        let mut last = self.after;
        let mut n = number;
        let mut stop = false;
        loop {
            let row = match rows.next() {
                Ok(Some(r)) => r,
                Ok(None) => break,
                Err(e) => {
                    out.push_back(Err(FormatError::file(
                        &self.file,
                        format!("cannot read: {e}"),
                    )
                    .in_layer(&self.layer)
                    .at_record(n + 1)));
                    stop = true;
                    break;
                }
            };
            n += 1;
            let fid: i64 = row.get(0).unwrap_or(last);
            last = fid;
            out.push_back(self.row(row, fid, n));
        }
        drop(rows);
        drop(stmt);
        if out.is_empty() || stop {
            self.done = true;
        }
        self.after = last;
        self.number = n;
        self.page = out;
        Ok(())
    }

    fn row(&self, row: &rusqlite::Row<'_>, fid: i64, n: u64) -> FeatureResult {
        let geometry = match row.get_ref(1) {
            Ok(ValueRef::Null) => Value::Null,
            Ok(ValueRef::Blob(b)) => match wkb::read_gpkg(b) {
                Ok(g) => {
                    if g.srs_id != self.srs_id as i32 && g.srs_id != 0 {
                        return Err(self.fail(
                            n,
                            format!(
                                "feature id {fid}: its geometry has srs_id {} but the table's is {}",
                                g.srs_id, self.srs_id
                            ),
                        ));
                    }
                    g.geometry
                }
                Err(e) => {
                    return Err(self.fail(
                        n,
                        format!(
                            "feature id {fid}: the geometry blob is corrupt at byte {} of its {} bytes: {}",
                            e.offset,
                            b.len(),
                            e.reason
                        ),
                    ))
                }
            },
            Ok(_) => {
                return Err(self.fail(n, format!("feature id {fid}: the geometry is not a blob")))
            }
            Err(e) => return Err(self.fail(n, e.to_string())),
        };
        let mut geometry = geometry;
        if !geometry.is_null() {
            self.crs
                .to_lonlat(&mut geometry)
                .map_err(|e| self.fail(n, format!("feature id {fid}: {e}")))?;
        }
        let mut props = Map::with_capacity(self.columns.len());
        for (i, c) in self.columns.iter().enumerate() {
            let v = row
                .get_ref(i + 2)
                .map_err(|e| self.fail(n, format!("column {:?}: {e}", c.name)))?;
            props.insert(c.name.clone(), value(v, &c.kind));
        }
        Ok(feature(geometry, props, Some(Value::from(fid))))
    }
}

/// The JSON value of a cell of declared type `kind`.
fn value(v: ValueRef<'_>, kind: &str) -> Value {
    match v {
        ValueRef::Null => Value::Null,
        ValueRef::Integer(i) if kind == "BOOLEAN" => Value::Bool(i != 0),
        ValueRef::Integer(i) => Value::from(i),
        ValueRef::Real(x) => super::number(x),
        ValueRef::Text(t) => Value::String(String::from_utf8_lossy(t).into_owned()),
        ValueRef::Blob(b) => Value::String(base64::engine::general_purpose::STANDARD.encode(b)),
    }
}

impl Iterator for Rows {
    type Item = FeatureResult;

    fn next(&mut self) -> Option<FeatureResult> {
        if let Some(f) = self.page.pop_front() {
            return Some(f);
        }
        if self.done {
            return None;
        }
        if let Err(e) = self.fetch() {
            self.done = true;
            return Some(Err(e));
        }
        self.page.pop_front()
    }
}
