//! FlatGeobuf, read feature by feature with the `flatgeobuf` crate (FlatBuffers verified).
//!
//! The header's CRS (`code` with `org` EPSG, or its WKT) decides the transformation; a file
//! with no CRS is taken as lon/lat. Columns keep their types (integers, reals, booleans,
//! strings, JSON columns parsed, date-times as their ISO 8601 text, binary as base64).
//! Reading goes through a byte counter, so an error names the byte where it was found; a
//! panic inside the third-party reader (a bug there) is caught and reported as that
//! record's error, never taking the process down.

use crate::formats::crs::Crs;
use crate::formats::{feature, FeatureResult, FormatError, Layer, ReadOptions};
use base64::Engine;
use flatgeobuf::{FallibleStreamingIterator, FeatureIter, FgbReader, NotSeekable};
use geozero::{ColumnValue, FeatureProperties, PropertyProcessor, ToJson};
use serde_json::{Map, Value};
use std::fs::File;
use std::io::{self, BufReader, Read};
use std::path::Path;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

/// A reader counting the bytes it hands out.
struct Counted<R> {
    inner: R,
    count: Arc<AtomicU64>,
}

impl<R: Read> Read for Counted<R> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        let n = self.inner.read(buf)?;
        self.count.fetch_add(n as u64, Ordering::Relaxed);
        Ok(n)
    }
}

type Iter = FeatureIter<Counted<BufReader<File>>, NotSeekable>;

/// Opens a FlatGeobuf file (one layer, named by the file's stem).
pub fn open(path: &Path, name: &str, options: &ReadOptions) -> Result<Vec<Layer>, FormatError> {
    super::single_layer(name, super::Kind::FlatGeobuf, options)?;
    let file =
        File::open(path).map_err(|e| FormatError::file(name, format!("cannot open: {e}")))?;
    let count = Arc::new(AtomicU64::new(0));
    let reader = Counted {
        inner: BufReader::with_capacity(256 << 10, file),
        count: count.clone(),
    };
    let opened = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| FgbReader::open(reader)));
    let fgb = match opened {
        Ok(Ok(r)) => r,
        Ok(Err(e)) => {
            return Err(
                FormatError::file(name, format!("not a readable FlatGeobuf file: {e}"))
                    .at_byte(count.load(Ordering::Relaxed)),
            )
        }
        Err(_) => {
            return Err(FormatError::file(name, "the FlatGeobuf header is corrupt").at_byte(0))
        }
    };
    let header = fgb.header();
    let crs = match header.crs() {
        None => Crs::unstated(),
        Some(c) => {
            let org = c.org().unwrap_or("EPSG");
            if c.code() != 0 && org.eq_ignore_ascii_case("EPSG") {
                Crs::from_epsg(i64::from(c.code()))
            } else if let Some(wkt) = c.wkt().filter(|w| !w.trim().is_empty()) {
                Crs::from_wkt(wkt)
            } else if c.code() == 0 {
                Ok(Crs::unstated())
            } else {
                Err(format!("the CRS {org}:{} is not an EPSG code", c.code()))
            }
            .map_err(|e| FormatError::file(name, e))?
        }
    };
    let columns: Vec<String> = header
        .columns()
        .map(|cs| cs.iter().map(|c| c.name().to_string()).collect())
        .unwrap_or_default();
    let layer = header
        .name()
        .filter(|n| !n.is_empty())
        .map(str::to_string)
        .or_else(|| path.file_stem().map(|s| s.to_string_lossy().into_owned()))
        .unwrap_or_default();
    let iter = fgb.select_all_seq().map_err(|e| {
        FormatError::file(name, format!("cannot read: {e}")).at_byte(count.load(Ordering::Relaxed))
    })?;
    Ok(vec![Layer {
        name: layer,
        crs: crs.clone(),
        features: Box::new(Features {
            iter,
            file: name.to_string(),
            count,
            crs,
            columns,
            number: 0,
            done: false,
        }),
    }])
}

struct Features {
    iter: Iter,
    file: String,
    count: Arc<AtomicU64>,
    crs: Crs,
    /// The header's columns: a property a feature leaves out is `null`, as GDAL reads it.
    columns: Vec<String>,
    number: u64,
    done: bool,
}

impl Features {
    fn fail(&self, why: String) -> FormatError {
        FormatError::file(&self.file, why)
            .at_record(self.number)
            .at_byte(self.count.load(Ordering::Relaxed))
    }

    fn read_next(&mut self) -> Result<Option<Value>, FormatError> {
        let columns = &self.columns;
        let step = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            let f = match self.iter.next() {
                Ok(Some(f)) => f,
                Ok(None) => return Ok(None),
                Err(e) => return Err(format!("cannot read the feature: {e}")),
            };
            let geometry = match f.geometry() {
                None => Value::Null,
                Some(_) => {
                    let text = f
                        .to_json()
                        .map_err(|e| format!("its geometry cannot be read: {e}"))?;
                    serde_json::from_str(&text)
                        .map_err(|e| format!("its geometry cannot be read: {e}"))?
                }
            };
            let mut props = Properties(columns.iter().map(|c| (c.clone(), Value::Null)).collect());
            f.process_properties(&mut props)
                .map_err(|e| format!("its properties cannot be read: {e}"))?;
            Ok(Some((geometry, props.0)))
        }));
        self.number += 1;
        match step {
            Ok(Ok(None)) => {
                self.number -= 1;
                Ok(None)
            }
            Ok(Ok(Some((mut geometry, props)))) => {
                if !geometry.is_null() {
                    self.crs
                        .to_lonlat(&mut geometry)
                        .map_err(|e| self.fail(e))?;
                }
                Ok(Some(feature(geometry, props, None)))
            }
            Ok(Err(why)) => Err(self.fail(why)),
            Err(_) => {
                Err(self.fail("the feature is corrupt (the FlatGeobuf reader failed on it)".into()))
            }
        }
    }
}

impl Iterator for Features {
    type Item = FeatureResult;

    fn next(&mut self) -> Option<FeatureResult> {
        if self.done {
            return None;
        }
        match self.read_next() {
            Ok(Some(f)) => Some(Ok(f)),
            Ok(None) => {
                self.done = true;
                None
            }
            Err(e) => {
                self.done = true;
                Some(Err(e))
            }
        }
    }
}

/// Collects a feature's properties with their types.
struct Properties(Map<String, Value>);

impl PropertyProcessor for Properties {
    fn property(
        &mut self,
        _idx: usize,
        name: &str,
        v: &ColumnValue,
    ) -> geozero::error::Result<bool> {
        let value = match v {
            ColumnValue::Byte(x) => Value::from(*x),
            ColumnValue::UByte(x) => Value::from(*x),
            ColumnValue::Bool(x) => Value::from(*x),
            ColumnValue::Short(x) => Value::from(*x),
            ColumnValue::UShort(x) => Value::from(*x),
            ColumnValue::Int(x) => Value::from(*x),
            ColumnValue::UInt(x) => Value::from(*x),
            ColumnValue::Long(x) => Value::from(*x),
            ColumnValue::ULong(x) => Value::from(*x),
            ColumnValue::Float(x) => super::number(f64::from(*x)),
            ColumnValue::Double(x) => super::number(*x),
            ColumnValue::String(s) | ColumnValue::DateTime(s) => Value::from(*s),
            ColumnValue::Json(s) => serde_json::from_str(s).unwrap_or_else(|_| Value::from(*s)),
            ColumnValue::Binary(b) => {
                Value::from(base64::engine::general_purpose::STANDARD.encode(b))
            }
        };
        self.0.insert(name.to_string(), value);
        Ok(false)
    }
}
