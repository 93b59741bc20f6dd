//! dBASE III tables (a Shapefile's `.dbf`): read record by record, and written with a clear
//! error for a value that does not fit its field (never a silent cut).
//!
//! Field types read: `C` text, `N`/`F` numbers (an integer when the field has no decimals and
//! the value is one), `L` logical, `D` dates (`YYYY-MM-DD`), `I` 32-bit integers, `O` doubles;
//! blank values are `null`. Text is UTF-8 or Latin-1 as the `.cpg` says (without one: UTF-8
//! when the bytes are, else Latin-1).

use crate::formats::FormatError;
use serde_json::{Map, Value};
use std::io::{self, Read, Write};

/// The text encoding of a table.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Encoding {
    /// UTF-8.
    Utf8,
    /// ISO-8859-1 (and Windows-1252, read as ISO-8859-1).
    Latin1,
    /// Not stated: UTF-8 when the bytes are, else Latin-1.
    Unstated,
}

impl Encoding {
    /// The encoding a `.cpg` names.
    pub fn from_cpg(text: &str) -> Result<Encoding, String> {
        let t = text
            .trim()
            .to_ascii_uppercase()
            .replace(['-', '_', ' '], "");
        match t.as_str() {
            "UTF8" | "65001" => Ok(Encoding::Utf8),
            "ISO88591" | "LATIN1" | "88591" | "1252" | "CP1252" | "WINDOWS1252" | "ANSI1252" => {
                Ok(Encoding::Latin1)
            }
            "" => Ok(Encoding::Unstated),
            _ => Err(format!(
                "the .cpg names the encoding {:?}, which is not read here (UTF-8, ISO-8859-1 and Windows-1252 are)",
                text.trim()
            )),
        }
    }

    fn decode(self, bytes: &[u8]) -> String {
        match self {
            Encoding::Utf8 => String::from_utf8_lossy(bytes).into_owned(),
            Encoding::Latin1 => bytes.iter().map(|&b| char::from(b)).collect(),
            Encoding::Unstated => match std::str::from_utf8(bytes) {
                Ok(s) => s.to_string(),
                Err(_) => bytes.iter().map(|&b| char::from(b)).collect(),
            },
        }
    }
}

/// One field of a table.
#[derive(Clone, Debug)]
pub struct Field {
    pub name: String,
    pub kind: u8,
    pub length: usize,
    pub decimals: usize,
    /// Offset within a record (after the deletion flag).
    offset: usize,
}

/// A table read record by record.
pub struct DbfReader<R> {
    r: R,
    file: String,
    pub fields: Vec<Field>,
    records: u32,
    header_len: u64,
    record_len: usize,
    encoding: Encoding,
    next: u32,
    buf: Vec<u8>,
}

/// Most fields a table may have (dBASE allows 255; the header would be larger than its
/// 16-bit length otherwise).
const MAX_FIELDS: usize = 2046;

impl<R: Read> DbfReader<R> {
    /// Reads the header of the table in `r` (named `file` in messages).
    pub fn new(mut r: R, file: &str, encoding: Encoding) -> Result<Self, FormatError> {
        let err = |byte: u64, why: String| FormatError::file(file, why).at_byte(byte);
        let mut head = [0u8; 32];
        read_exact(&mut r, &mut head).map_err(|e| err(0, format!("the table header is {e}")))?;
        let records = u32::from_le_bytes([head[4], head[5], head[6], head[7]]);
        let header_len = u16::from_le_bytes([head[8], head[9]]) as u64;
        let record_len = u16::from_le_bytes([head[10], head[11]]) as usize;
        if header_len < 33 || record_len == 0 {
            return Err(err(
                8,
                format!(
                    "not a dBASE table: header length {header_len}, record length {record_len}"
                ),
            ));
        }
        let n_fields = ((header_len - 33) / 32) as usize;
        if n_fields > MAX_FIELDS {
            return Err(err(8, format!("{n_fields} fields: at most {MAX_FIELDS}")));
        }
        let mut fields = Vec::with_capacity(n_fields);
        let mut offset = 0usize;
        let mut at = 32u64;
        loop {
            let mut first = [0u8; 1];
            read_exact(&mut r, &mut first)
                .map_err(|e| err(at, format!("the field descriptors are {e}")))?;
            if first[0] == 0x0d {
                at += 1;
                break;
            }
            let mut d = [0u8; 32];
            d[0] = first[0];
            read_exact(&mut r, &mut d[1..])
                .map_err(|e| err(at, format!("a field descriptor is {e}")))?;
            if fields.len() == n_fields {
                return Err(err(
                    at,
                    "more field descriptors than the header length allows".into(),
                ));
            }
            let end = d[..11].iter().position(|&b| b == 0).unwrap_or(11);
            let name = encoding.decode(&d[..end]).trim().to_string();
            let length = d[16] as usize;
            fields.push(Field {
                name,
                kind: d[11],
                length,
                decimals: d[17] as usize,
                offset,
            });
            offset += length;
            at += 32;
        }
        if offset + 1 > record_len {
            return Err(err(
                10,
                format!(
                    "the fields take {} bytes but a record has {record_len}",
                    offset + 1
                ),
            ));
        }
        // Skip to the first record (some writers leave bytes after the terminator).
        if at < header_len {
            io::copy(&mut (&mut r).take(header_len - at), &mut io::sink())
                .map_err(|e| err(at, format!("cannot read: {e}")))?;
        }
        Ok(DbfReader {
            r,
            file: file.to_string(),
            fields,
            records,
            header_len,
            record_len,
            encoding,
            next: 0,
            buf: vec![0; record_len],
        })
    }

    /// The number of records the header states.
    pub fn len(&self) -> u32 {
        self.records
    }

    /// Reads the next record's attributes (`None` after the last one). A deleted record is
    /// `Some(Ok(None))`: its shape is still in the `.shp` and is skipped with it.
    pub fn next_record(&mut self) -> Option<Result<Option<Map<String, Value>>, FormatError>> {
        if self.next >= self.records {
            return None;
        }
        let number = u64::from(self.next) + 1;
        let start = self.header_len + u64::from(self.next) * self.record_len as u64;
        self.next += 1;
        let fail = |byte: u64, why: String| {
            Some(Err(FormatError::file(&self.file, why)
                .at_record(number)
                .at_byte(byte)))
        };
        if let Err(e) = read_exact(&mut self.r, &mut self.buf) {
            return fail(start, format!("the attribute record is {e}"));
        }
        if self.buf[0] == b'*' {
            return Some(Ok(None));
        }
        let mut props = Map::with_capacity(self.fields.len());
        for f in &self.fields {
            let raw = &self.buf[1 + f.offset..1 + f.offset + f.length];
            let byte = start + 1 + f.offset as u64;
            match self.value(f, raw) {
                Ok(v) => {
                    props.insert(f.name.clone(), v);
                }
                Err(why) => return fail(byte, format!("field {:?}: {why}", f.name)),
            }
        }
        Some(Ok(Some(props)))
    }

    fn value(&self, f: &Field, raw: &[u8]) -> Result<Value, String> {
        let text = || self.encoding.decode(raw);
        match f.kind {
            // As GDAL reads them: trailing blanks trimmed, an empty text is NULL.
            b'C' => {
                let t = text();
                let t = t.trim_end_matches([' ', '\0']);
                Ok(if t.is_empty() {
                    Value::Null
                } else {
                    Value::String(t.to_string())
                })
            }
            b'N' | b'F' => {
                let t = text();
                let t = t.trim().trim_matches('\0');
                if t.is_empty() || t.chars().all(|c| c == '*') {
                    return Ok(Value::Null);
                }
                if f.decimals == 0 {
                    if let Ok(i) = t.parse::<i64>() {
                        return Ok(Value::from(i));
                    }
                }
                t.parse::<f64>()
                    .ok()
                    .filter(|x| x.is_finite())
                    .map(super::number)
                    .ok_or_else(|| format!("{t:?} is not a number"))
            }
            b'L' => Ok(match raw.first().map(u8::to_ascii_uppercase) {
                Some(b'T' | b'Y') => Value::Bool(true),
                Some(b'F' | b'N') => Value::Bool(false),
                _ => Value::Null,
            }),
            b'D' => {
                let t = text();
                let t = t.trim();
                if t.is_empty() || t.chars().all(|c| c == '0') {
                    return Ok(Value::Null);
                }
                if t.len() == 8 && t.bytes().all(|b| b.is_ascii_digit()) {
                    Ok(Value::String(format!(
                        "{}-{}-{}",
                        &t[..4],
                        &t[4..6],
                        &t[6..]
                    )))
                } else {
                    Err(format!("{t:?} is not a date (YYYYMMDD)"))
                }
            }
            b'I' if raw.len() == 4 => Ok(Value::from(i32::from_le_bytes([
                raw[0], raw[1], raw[2], raw[3],
            ]))),
            b'O' if raw.len() == 8 => {
                let mut b = [0u8; 8];
                b.copy_from_slice(raw);
                Ok(super::number(f64::from_le_bytes(b)))
            }
            // Memo fields point into a .dbt that Shapefiles do not have: read as text.
            _ => Ok(Value::String(text().trim_end().to_string())),
        }
    }
}

/// `read_exact`, with "truncated" for an early end.
fn read_exact(r: &mut impl Read, buf: &mut [u8]) -> Result<(), String> {
    r.read_exact(buf).map_err(|e| {
        if e.kind() == io::ErrorKind::UnexpectedEof {
            "truncated (the file ends early)".to_string()
        } else {
            format!("unreadable: {e}")
        }
    })
}

/// The type of a column to write.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ColumnType {
    /// `N`, no decimals.
    Integer,
    /// `N` with decimals.
    Real,
    /// `L`.
    Boolean,
    /// `C` (anything else is written as its JSON text).
    Text,
}

/// A column to write: its name in the table (at most 10 bytes), type and width.
#[derive(Clone, Debug)]
pub struct Column {
    pub name: String,
    pub kind: ColumnType,
    pub length: usize,
    pub decimals: usize,
}

/// The widest text field.
pub const MAX_TEXT: usize = 254;
/// Width and decimals of a real column (as GDAL writes them).
pub const REAL_WIDTH: usize = 24;
pub const REAL_DECIMALS: usize = 15;

/// Writes the header of a table of `records` records and `columns` (UTF-8 text).
pub fn write_header(out: &mut impl Write, columns: &[Column], records: u32) -> io::Result<()> {
    let record_len: usize = 1 + columns.iter().map(|c| c.length).sum::<usize>();
    let header_len = 32 + 32 * columns.len() + 1;
    let mut h = [0u8; 32];
    h[0] = 0x03;
    h[1..4].copy_from_slice(&[126, 1, 1]);
    h[4..8].copy_from_slice(&records.to_le_bytes());
    h[8..10].copy_from_slice(&(header_len as u16).to_le_bytes());
    h[10..12].copy_from_slice(&(record_len as u16).to_le_bytes());
    out.write_all(&h)?;
    for c in columns {
        let mut d = [0u8; 32];
        let name = c.name.as_bytes();
        d[..name.len().min(10)].copy_from_slice(&name[..name.len().min(10)]);
        d[11] = match c.kind {
            ColumnType::Integer | ColumnType::Real => b'N',
            ColumnType::Boolean => b'L',
            ColumnType::Text => b'C',
        };
        d[16] = c.length as u8;
        d[17] = c.decimals as u8;
        out.write_all(&d)?;
    }
    out.write_all(&[0x0d])
}

/// The bytes of `value` in column `c`, or why it does not fit.
pub fn encode(c: &Column, value: &Value) -> Result<Vec<u8>, String> {
    let pad_left = |s: String| -> Result<Vec<u8>, String> {
        if s.len() > c.length {
            return Err(format!(
                "the value {s} does not fit the field {:?} ({} characters)",
                c.name, c.length
            ));
        }
        Ok(format!("{s:>width$}", width = c.length).into_bytes())
    };
    match (c.kind, value) {
        (_, Value::Null) => Ok(vec![b' '; c.length]),
        (ColumnType::Integer, Value::Number(n)) if n.as_i64().is_some() || n.as_u64().is_some() => {
            pad_left(n.to_string())
        }
        (ColumnType::Real | ColumnType::Integer, Value::Number(n)) => {
            let x = n.as_f64().unwrap_or(f64::NAN);
            pad_left(format!("{x:.prec$}", prec = c.decimals))
        }
        (ColumnType::Boolean, Value::Bool(b)) => Ok(vec![if *b { b'T' } else { b'F' }]),
        (ColumnType::Text, v) => {
            let s = match v {
                Value::String(s) => s.clone(),
                other => other.to_string(),
            };
            if s.len() > c.length {
                return Err(format!(
                    "a text of {} bytes does not fit the field {:?} (at most {} bytes in a DBF field)",
                    s.len(),
                    c.name,
                    c.length
                ));
            }
            let mut b = s.into_bytes();
            b.resize(c.length, b' ');
            Ok(b)
        }
        (_, v) => Err(format!(
            "the value {v} does not fit the field {:?} ({:?})",
            c.name, c.kind
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn writes_and_reads_back_and_refuses_overflow() {
        let columns = vec![
            Column {
                name: "name".into(),
                kind: ColumnType::Text,
                length: 5,
                decimals: 0,
            },
            Column {
                name: "n".into(),
                kind: ColumnType::Integer,
                length: 4,
                decimals: 0,
            },
            Column {
                name: "x".into(),
                kind: ColumnType::Real,
                length: REAL_WIDTH,
                decimals: REAL_DECIMALS,
            },
            Column {
                name: "ok".into(),
                kind: ColumnType::Boolean,
                length: 1,
                decimals: 0,
            },
        ];
        let rows = [
            [json!("Åsa"), json!(12), json!(1.25), json!(true)],
            [Value::Null, json!(-5), Value::Null, json!(false)],
        ];
        let mut b = Vec::new();
        write_header(&mut b, &columns, 2).unwrap();
        for r in &rows {
            b.push(b' ');
            for (c, v) in columns.iter().zip(r) {
                b.extend(encode(c, v).unwrap());
            }
        }
        let mut t = DbfReader::new(&b[..], "t.dbf", Encoding::Utf8).unwrap();
        let first = t.next_record().unwrap().unwrap().unwrap();
        assert_eq!(first["name"], json!("Åsa"));
        assert_eq!(first["n"], json!(12));
        assert_eq!(first["x"], json!(1.25));
        assert_eq!(first["ok"], json!(true));
        let second = t.next_record().unwrap().unwrap().unwrap();
        assert!(second["name"].is_null());
        assert!(second["x"].is_null());
        assert!(t.next_record().is_none());
        assert!(encode(&columns[0], &json!("toolong"))
            .unwrap_err()
            .contains("\"name\""));
        assert!(encode(&columns[1], &json!(123456)).is_err());
        // Truncated: the error names the record and its byte.
        let cut = b.len() - 3;
        let mut t = DbfReader::new(&b[..cut], "t.dbf", Encoding::Utf8).unwrap();
        t.next_record().unwrap().unwrap();
        let e = t.next_record().unwrap().unwrap_err();
        assert_eq!(e.record, Some(2));
        assert!(e.to_string().contains("truncated"), "{e}");
    }
}
