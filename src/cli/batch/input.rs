//! Inputs read as a stream of records, whatever their format.
//!
//! * A GeoJSON text sequence (RFC 8142, `--format seq`): records are split at the RS byte
//!   (0x1E); each is parsed on a worker thread, so one bad record is reported and skipped.
//! * Newline-delimited GeoJSON (`--format lines`): one JSON text per line, split at LF.
//! * One GeoJSON document (`--format geojson`): a FeatureCollection is parsed incrementally
//!   with serde, its `features` handed on one by one as they are read (the collection is never
//!   held whole as parsed values; a file of up to [`READ_WHOLE_BYTES`] is read into memory as
//!   bytes first, larger files and stdin are streamed); a Feature, a geometry or a spline
//!   document is one record.
//!
//! [`detect`] tells them apart by looking at the start of the input only (at most
//! [`SNIFF_LIMIT`] bytes): a leading RS is a text sequence; a first line that is a complete
//! JSON text (other than a FeatureCollection) followed by more text is newline-delimited;
//! anything else is one document.

use crate::formats::{FormatError, Kind, ReadOptions, Source};
use serde::de::{self, DeserializeSeed, MapAccess, SeqAccess, Visitor};
use serde::Deserialize;
use serde_json::value::RawValue;
use serde_json::{Map, Value};
use std::fmt;
use std::io::{self, BufRead, BufReader, Cursor, Read};
use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

/// The record separator of RFC 8142 text sequences.
pub const RS: u8 = 0x1e;

/// The most bytes [`detect`] reads to find the end of the first line. A longer first line is
/// taken to be (the start of) one GeoJSON document; 4 MiB holds a 100,000-point Feature.
pub const SNIFF_LIMIT: u64 = 4 << 20;

/// Read buffer size: large enough that reads are few, small next to the memory bound.
const BUFFER_BYTES: usize = 256 << 10;

/// The buffer serde_json reads a document from byte by byte (see `read_document`).
const PARSE_BUFFER_BYTES: usize = 64 << 10;

/// A document file of at most this size is read into memory first and parsed from there:
/// serde_json skips through a slice several times faster than through a reader, byte by byte
/// (on the 16 MB 10m land outlines the reading took 0.84 G instructions, now 0.25 G).
/// Less than the pipeline's window of input in flight
/// ([`super::pipeline::WINDOW_BYTES`]), so the memory bound stays what it was.
pub const READ_WHOLE_BYTES: u64 = 32 << 20;

/// Input and output formats.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Format {
    /// Detect the input format; write the output in the input's format
    Auto,
    /// One GeoJSON document (FeatureCollection, Feature or geometry); written as a
    /// FeatureCollection
    #[value(alias = "json")]
    Geojson,
    /// GeoJSON text sequence (RFC 8142): each record is RS (0x1E), a JSON text, LF
    #[value(alias = "geojsons", alias = "geojsonseq")]
    Seq,
    /// Newline-delimited GeoJSON: one JSON text (usually a Feature) per line
    #[value(alias = "geojsonl", alias = "ndjson", alias = "jsonl")]
    Lines,
    /// TopoJSON topology: read (each object's geometries; --layer picks an object); written
    /// with `fit --topology shared`
    Topojson,
    /// ESRI Shapefile (.shp with its .dbf, .prj, .cpg, or one .zip); written with -o FILE.shp
    #[value(alias = "shp")]
    Shapefile,
    /// OGC GeoPackage (every feature table, or --layer); written with -o FILE.gpkg
    #[value(alias = "geopackage")]
    Gpkg,
    /// FlatGeobuf; written with -o FILE.fgb
    #[value(alias = "flatgeobuf")]
    Fgb,
    /// GPX (waypoints, routes, tracks with their times); written (tracks and waypoints) with
    /// -o FILE.gpx
    Gpx,
}

impl Format {
    /// The file format of [`crate::formats`] this is, if it is one (TopoJSON as input).
    pub fn kind(self) -> Option<Kind> {
        match self {
            Format::Shapefile => Some(Kind::Shapefile),
            Format::Gpkg => Some(Kind::GeoPackage),
            Format::Fgb => Some(Kind::FlatGeobuf),
            Format::Gpx => Some(Kind::Gpx),
            Format::Topojson => Some(Kind::TopoJson),
            _ => None,
        }
    }

    /// The format of a [`Kind`].
    pub fn of_kind(kind: Kind) -> Format {
        match kind {
            Kind::Shapefile => Format::Shapefile,
            Kind::GeoPackage => Format::Gpkg,
            Kind::FlatGeobuf => Format::Fgb,
            Kind::Gpx => Format::Gpx,
            Kind::TopoJson => Format::Topojson,
        }
    }

    /// True for the formats written through [`crate::formats::write`] (a file, not a stream).
    pub fn is_file_output(self) -> bool {
        matches!(
            self,
            Format::Shapefile | Format::Gpkg | Format::Fgb | Format::Gpx
        )
    }
}

/// One input named on the command line (or stdin).
#[derive(Clone, Debug)]
pub struct Input {
    /// The name in messages: the path as given, or `stdin`.
    pub name: String,
    /// `None` for stdin.
    pub path: Option<PathBuf>,
    /// Size in bytes when known (regular files), for the ETA.
    pub size: Option<u64>,
}

/// A byte counter under the read buffer, shared with the pipeline for progress and sizes.
struct Counting<R> {
    inner: R,
    count: Arc<AtomicU64>,
}

impl<R: Read> Read for Counting<R> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        let n = self.inner.read(buf)?;
        self.count.fetch_add(n as u64, Ordering::Relaxed);
        Ok(n)
    }
}

/// The UTF-8 byte order mark, which some editors write at the start of a file.
const BOM: [u8; 3] = [0xef, 0xbb, 0xbf];

/// A reader that drops a leading UTF-8 byte order mark: RFC 8259 lets a parser ignore one, and
/// the service does; everything after it (the format probe, the whole-file and the streamed
/// document paths, sequences) reads the input without it. Bytes are counted below it, so
/// progress still adds up to the file's size.
struct SkipBom<R> {
    inner: R,
    /// The first bytes (up to 3) while they are being served, and how many were served.
    head: Option<([u8; 3], usize, usize)>,
    started: bool,
}

impl<R: Read> SkipBom<R> {
    fn new(inner: R) -> Self {
        SkipBom {
            inner,
            head: None,
            started: false,
        }
    }
}

impl<R: Read> Read for SkipBom<R> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        if !self.started {
            // Up to three bytes, however the input hands them out (a pipe may give one).
            let mut first = [0u8; 3];
            let mut n = 0;
            while n < 3 {
                match self.inner.read(&mut first[n..]) {
                    Ok(0) => break,
                    Ok(k) => n += k,
                    Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                    Err(e) => return Err(e),
                }
            }
            self.started = true;
            if first != BOM {
                self.head = Some((first, 0, n));
            }
        }
        if let Some((first, at, n)) = &mut self.head {
            if *at < *n {
                let k = (*n - *at).min(buf.len());
                buf[..k].copy_from_slice(&first[*at..*at + k]);
                *at += k;
                return Ok(k);
            }
            self.head = None;
        }
        self.inner.read(buf)
    }
}

/// An input opened and its format known.
pub struct Opened {
    /// Index of the input on the command line.
    pub index: usize,
    pub format: Format,
    reader: Box<dyn BufRead + Send>,
    /// Bytes read from the input so far (a little ahead of what has been parsed).
    count: Arc<AtomicU64>,
    /// The input is a file of this size, at most [`READ_WHOLE_BYTES`]: a document is read whole
    /// first (as long as the file has not grown since).
    whole: Option<usize>,
    /// A file of one of [`crate::formats`]: its layers, read instead of `reader`.
    source: Option<Source>,
    /// What the user should know of the input (its CRS, when it was transformed).
    pub notes: Vec<String>,
}

/// How many bytes to look at to find a file's format by its content.
const MAGIC_BYTES: usize = 1024;

/// Opens a file of [`crate::formats`] (`kind`, or found from its content and name).
fn open_file_format(
    input: &Input,
    index: usize,
    forced: Format,
    options: &ReadOptions,
) -> Result<Option<Opened>, String> {
    let Some(path) = &input.path else {
        return match forced.kind() {
            Some(k) => Err(format!(
                "stdin: {} is read from a file, not stdin: name the file",
                k.name()
            )),
            None => Ok(None),
        };
    };
    let kind = match forced.kind() {
        Some(k) => k,
        None if forced != Format::Auto => return Ok(None),
        None => {
            let mut head = Vec::with_capacity(MAGIC_BYTES);
            std::fs::File::open(path)
                .and_then(|f| f.take(MAGIC_BYTES as u64).read_to_end(&mut head))
                .map_err(|e| format!("{}: cannot open: {e}", input.name))?;
            match Kind::detect(Some(path), &head) {
                Some(k) => k,
                None => return Ok(None),
            }
        }
    };
    let source = crate::formats::open(path, &input.name, kind, options)
        .map_err(|e: FormatError| e.to_string())?;
    let notes = source
        .layers
        .iter()
        .filter(|l| !l.crs.is_lonlat())
        .map(|l| {
            format!(
                "{}: layer {:?}: coordinates in {} transformed to lon/lat (EPSG:4326)",
                input.name, l.name, l.crs.name
            )
        })
        .collect();
    Ok(Some(Opened {
        index,
        format: Format::of_kind(kind),
        reader: Box::new(io::empty()),
        count: Arc::new(AtomicU64::new(0)),
        whole: None,
        source: Some(source),
        notes,
    }))
}

/// Opens input `index` and finds its format (`forced` unless it is [`Format::Auto`]).
///
/// # Errors
/// The file cannot be opened or read (the message names it).
pub fn open(
    input: &Input,
    index: usize,
    forced: Format,
    options: &ReadOptions,
) -> Result<Opened, String> {
    if let Some(opened) = open_file_format(input, index, forced, options)? {
        return Ok(opened);
    }
    if options.layer.is_some() {
        return Err(format!(
            "{}: --layer picks a layer of a GeoPackage, a zipped Shapefile, a GPX or a TopoJSON file; this input is GeoJSON",
            input.name
        ));
    }
    let count = Arc::new(AtomicU64::new(0));
    let raw: Box<dyn Read + Send> = match &input.path {
        Some(p) => Box::new(
            std::fs::File::open(p).map_err(|e| format!("{}: cannot open: {e}", input.name))?,
        ),
        None => Box::new(io::stdin()),
    };
    let mut reader = BufReader::with_capacity(
        BUFFER_BYTES,
        SkipBom::new(Counting {
            inner: raw,
            count: count.clone(),
        }),
    );
    // A named file with no JSON value in it (empty, or only a byte order mark and spaces) is
    // a mistake, not an empty stream; `--format lines` or `seq` reads it as zero records.
    if forced == Format::Auto
        && input.path.is_some()
        && !skip_space(&mut reader).map_err(|e| format!("{}: cannot read: {e}", input.name))?
    {
        return Err(format!(
            "{}: the file holds no JSON value (it is empty or only white space); \
             --format lines reads it as zero records",
            input.name
        ));
    }
    let (format, prefix) = if forced == Format::Auto {
        detect(&mut reader).map_err(|e| format!("{}: cannot read: {e}", input.name))?
    } else {
        (forced, Vec::new())
    };
    let reader: Box<dyn BufRead + Send> = if prefix.is_empty() {
        Box::new(reader)
    } else {
        Box::new(BufReader::with_capacity(
            BUFFER_BYTES,
            Cursor::new(prefix).chain(reader),
        ))
    };
    Ok(Opened {
        index,
        format,
        reader,
        count,
        whole: input
            .size
            .filter(|&n| n <= READ_WHOLE_BYTES)
            .map(|n| n as usize),
        source: None,
        notes: Vec::new(),
    })
}

fn is_json_space(b: u8) -> bool {
    matches!(b, b' ' | b'\t' | b'\n' | b'\r')
}

/// Consumes leading JSON whitespace; true when the input has more after it.
fn skip_space(r: &mut dyn BufRead) -> io::Result<bool> {
    loop {
        let buf = r.fill_buf()?;
        if buf.is_empty() {
            return Ok(false);
        }
        let n = buf.iter().take_while(|b| is_json_space(**b)).count();
        let more = n < buf.len();
        r.consume(n);
        if more {
            return Ok(true);
        }
    }
}

/// Finds the format of an input from its start, returning the bytes it consumed beyond
/// leading whitespace (to be read again).
///
/// An empty input is an empty sequence ([`Format::Lines`]): it has no records (an empty
/// named file is refused before this, in [`open`]).
pub fn detect(r: &mut dyn BufRead) -> io::Result<(Format, Vec<u8>)> {
    if !skip_space(r)? {
        return Ok((Format::Lines, Vec::new()));
    }
    if r.fill_buf()?[0] == RS {
        return Ok((Format::Seq, Vec::new()));
    }
    let mut first = Vec::new();
    let n = Read::take(&mut *r, SNIFF_LIMIT).read_until(b'\n', &mut first)?;
    let complete = first.ends_with(b"\n") || (n as u64) < SNIFF_LIMIT;
    if !complete {
        return Ok((Format::Geojson, first));
    }
    let format = match probe_type(&first) {
        Some(Some(kind)) if kind == "FeatureCollection" => Format::Geojson,
        Some(_) if skip_space(r)? => Format::Lines,
        _ => Format::Geojson,
    };
    Ok((format, first))
}

/// The `type` of the JSON text `text` when it is one complete JSON value: `Some(None)` for a
/// value without a string `type`, `None` when `text` is not one JSON value. Nothing but the
/// `type` is built: the first line can be a whole document of 4 MiB.
fn probe_type(text: &[u8]) -> Option<Option<String>> {
    #[derive(serde::Deserialize)]
    struct Typed {
        #[serde(rename = "type")]
        kind: Option<String>,
    }
    let object = text.iter().find(|b| !is_json_space(**b)) == Some(&b'{');
    if object {
        if let Ok(t) = serde_json::from_slice::<Typed>(text) {
            return Some(t.kind);
        }
    }
    // Not an object with a string `type` (or none): still one JSON value?
    serde_json::from_slice::<serde::de::IgnoredAny>(text)
        .ok()
        .map(|_| None)
}

/// Where a record sits in its input.
#[derive(Clone, Debug, PartialEq)]
pub struct Position {
    /// Index of the input on the command line.
    pub input: usize,
    /// 1-based record number in the input (for a FeatureCollection, the feature number).
    pub number: usize,
    /// 1-based line number of a newline-delimited record.
    pub line: Option<usize>,
}

/// What a record holds.
#[derive(Debug)]
pub enum Body {
    /// One JSON text of a sequence, not yet parsed.
    Text(Vec<u8>),
    /// One member of a FeatureCollection's `features`, at `pointer` (`/features/3`), as read
    /// (checked JSON, not yet parsed): the worker that fits it parses it, not the reader.
    Feature { raw: Box<RawValue>, pointer: String },
    /// A whole document that is not a FeatureCollection (Feature, geometry, spline, ...).
    Document(Value),
}

/// One unit of work.
#[derive(Debug)]
pub struct Record {
    pub at: Position,
    pub body: Body,
    /// Input bytes it took (about, for collection members), for the memory window.
    pub bytes: usize,
}

/// What the reader hands on, in input order.
#[derive(Debug)]
pub enum Unit {
    Record(Record),
    /// Foreign members of a FeatureCollection (`type` and `features` removed).
    Members(Map<String, Value>),
}

/// Why reading stopped early.
#[derive(Debug)]
pub enum ReadError {
    /// The consumer stopped (output closed or failed): not an error of the input.
    Stopped,
    /// The input cannot be read on: an I/O error or a document that is not valid JSON.
    Fatal(String),
}

/// The consumer of units: blocks while the pipeline is full; `Err(())` when it has stopped.
pub type Emit<'a> = dyn FnMut(Unit, u64) -> Result<(), ()> + 'a;

impl Opened {
    /// The counter of bytes read from this input, to read after [`Opened::read`] consumed it.
    pub fn counter(&self) -> Arc<AtomicU64> {
        self.count.clone()
    }

    /// Bytes read from this input so far.
    pub fn bytes_read(&self) -> u64 {
        self.count.load(Ordering::Relaxed)
    }

    /// Reads every record, handing each to `emit` together with the input bytes read so far.
    ///
    /// # Errors
    /// [`ReadError::Fatal`] naming the input (and line and column for JSON syntax in a
    /// document), or [`ReadError::Stopped`].
    pub fn read(mut self, name: &str, emit: &mut Emit<'_>) -> Result<(), ReadError> {
        if let Some(source) = self.source.take() {
            return self.read_source(source, emit);
        }
        match self.format {
            Format::Seq => self.read_texts(name, RS, emit),
            Format::Lines => self.read_texts(name, b'\n', emit),
            Format::Geojson | Format::Auto | Format::Topojson => self.read_document(name, emit),
            Format::Shapefile | Format::Gpkg | Format::Fgb | Format::Gpx => Err(ReadError::Fatal(
                format!("{name}: the file was not opened as {:?}", self.format),
            )),
        }
    }

    /// Reads the features of every layer of a file of [`crate::formats`], numbered on from
    /// one across its layers. A feature that cannot be read stops the input (the file is
    /// corrupt): the error names the file, layer, record and byte.
    fn read_source(&mut self, source: Source, emit: &mut Emit<'_>) -> Result<(), ReadError> {
        let mut number = 0;
        let mut read = 0u64;
        for layer in source.layers {
            for f in layer.features {
                let f = f.map_err(|e| ReadError::Fatal(e.to_string()))?;
                number += 1;
                let bytes = approximate_size(&f);
                read += bytes as u64;
                self.count.store(read, Ordering::Relaxed);
                let unit = Unit::Record(Record {
                    at: Position {
                        input: self.index,
                        number,
                        line: None,
                    },
                    body: Body::Document(f),
                    bytes,
                });
                emit(unit, read).map_err(|()| ReadError::Stopped)?;
            }
        }
        Ok(())
    }

    fn read_texts(
        &mut self,
        name: &str,
        delimiter: u8,
        emit: &mut Emit<'_>,
    ) -> Result<(), ReadError> {
        let mut number = 0;
        let mut line = 1usize;
        loop {
            let mut buf = Vec::new();
            let n = self
                .reader
                .read_until(delimiter, &mut buf)
                .map_err(|e| ReadError::Fatal(format!("{name}: cannot read: {e}")))?;
            if n == 0 {
                return Ok(());
            }
            let this_line = line;
            if delimiter == b'\n' {
                line += 1;
            }
            let text = trim_record(&buf);
            if text.is_empty() {
                continue;
            }
            number += 1;
            let start = text.as_ptr() as usize - buf.as_ptr() as usize;
            let len = text.len();
            buf.truncate(start + len);
            buf.drain(..start);
            let unit = Unit::Record(Record {
                at: Position {
                    input: self.index,
                    number,
                    line: (delimiter == b'\n').then_some(this_line),
                },
                body: Body::Text(buf),
                bytes: n,
            });
            emit(unit, self.bytes_read()).map_err(|()| ReadError::Stopped)?;
        }
    }

    fn read_document(&mut self, name: &str, emit: &mut Emit<'_>) -> Result<(), ReadError> {
        let count = self.count.clone();
        let index = self.index;
        let mut stopped = false;
        let mut state = DocumentState {
            emit,
            count: &count,
            last: count.load(Ordering::Relaxed),
            index,
            stopped: &mut stopped,
        };
        let top = if let Some(size) = self.whole {
            // A file small enough is parsed from memory (see READ_WHOLE_BYTES). Read at most
            // one byte past its size when opened: a file that grew since is streamed on from
            // what was read, never held whole.
            let mut text = Vec::with_capacity(size + 1);
            (&mut self.reader)
                .take(size as u64 + 1)
                .read_to_end(&mut text)
                .map_err(|e| ReadError::Fatal(format!("{name}: cannot read: {e}")))?;
            if text.len() <= size {
                parse_top(serde_json::Deserializer::from_slice(&text), &mut state)
            } else {
                let rest = BufReader::with_capacity(
                    PARSE_BUFFER_BYTES,
                    Cursor::new(text).chain(&mut self.reader),
                );
                parse_top(serde_json::Deserializer::from_reader(rest), &mut state)
            }
        } else {
            // A concrete buffered reader on top: serde_json reads byte by byte, and through
            // the boxed reader each byte was a dynamic call (a tenth of a dataset's reading
            // time).
            let reader = BufReader::with_capacity(PARSE_BUFFER_BYTES, &mut self.reader);
            parse_top(serde_json::Deserializer::from_reader(reader), &mut state)
        };
        let top = match top {
            Ok(t) => t,
            Err(_) if stopped => return Err(ReadError::Stopped),
            Err(e) => {
                let hint = if e.to_string().contains("trailing characters") {
                    " (several JSON texts: use --format lines or --format seq)"
                } else {
                    ""
                };
                return Err(ReadError::Fatal(format!(
                    "{name}: not a valid GeoJSON document: {e}{hint}"
                )));
            }
        };
        match top {
            Top::Whole(value) => {
                let unit = Unit::Record(Record {
                    at: Position {
                        input: index,
                        number: 1,
                        line: None,
                    },
                    body: Body::Document(value),
                    bytes: count.load(Ordering::Relaxed) as usize,
                });
                state.emit(unit)
            }
            Top::Collection { before, after } => {
                let kind = before.get("type").or_else(|| after.get("type"));
                if kind.and_then(Value::as_str) != Some("FeatureCollection") {
                    return Err(ReadError::Fatal(format!(
                        "{name}: the document has \"features\" but its \"type\" is {}: expected \"FeatureCollection\"",
                        kind.map_or("missing".to_string(), Value::to_string)
                    )));
                }
                // The collection's own members are checked as the service checks them.
                let mut outer: Map<String, Value> = before.clone();
                outer.extend(after.clone());
                outer.insert("features".into(), Value::Array(Vec::new()));
                crate::earth::Document::parse(Value::Object(outer), false)
                    .map_err(|e| ReadError::Fatal(format!("{name}: {e}")))?;
                let mut after = after;
                after.remove("type");
                state.emit(Unit::Members(after))
            }
        }
    }
}

/// About the bytes a parsed feature would take as GeoJSON text (24 per number, 16 per other
/// value), for the pipeline's memory window: cheaper than serialising it.
fn approximate_size(v: &Value) -> usize {
    match v {
        Value::Array(a) => 2 + a.iter().map(approximate_size).sum::<usize>(),
        Value::Object(o) => {
            2 + o
                .iter()
                .map(|(k, v)| k.len() + 4 + approximate_size(v))
                .sum::<usize>()
        }
        Value::String(s) => s.len() + 2,
        Value::Number(_) => 24,
        _ => 16,
    }
}

/// Strips whitespace and stray record separators around a record.
fn trim_record(buf: &[u8]) -> &[u8] {
    let skip = |b: &u8| is_json_space(*b) || *b == RS;
    let start = buf.iter().position(|b| !skip(b)).unwrap_or(buf.len());
    let end = buf.iter().rposition(|b| !skip(b)).map_or(start, |i| i + 1);
    &buf[start..end.max(start)]
}

/// The reader's side of incremental document parsing.
struct DocumentState<'s, 'e> {
    emit: &'s mut Emit<'e>,
    count: &'s AtomicU64,
    /// Bytes read when the previous unit was emitted.
    last: u64,
    index: usize,
    stopped: &'s mut bool,
}

impl DocumentState<'_, '_> {
    fn emit(&mut self, mut unit: Unit) -> Result<(), ReadError> {
        let now = self.count.load(Ordering::Relaxed);
        if let Unit::Record(r) = &mut unit {
            if !matches!(r.body, Body::Document(_)) {
                r.bytes = now.saturating_sub(self.last) as usize;
            }
        }
        self.last = now;
        (self.emit)(unit, now).map_err(|()| {
            *self.stopped = true;
            ReadError::Stopped
        })
    }
}

/// The top-level value of a document.
enum Top {
    /// A FeatureCollection whose features were handed on while parsing: its other members,
    /// those before `features` and those after.
    Collection {
        before: Map<String, Value>,
        after: Map<String, Value>,
    },
    /// Anything else, whole.
    Whole(Value),
}

struct TopSeed<'a, 's, 'e> {
    state: &'a mut DocumentState<'s, 'e>,
}

/// The document from `de`, its features handed on as they are read, and nothing after it.
fn parse_top<'de, R: serde_json::de::Read<'de>>(
    mut de: serde_json::Deserializer<R>,
    state: &mut DocumentState<'_, '_>,
) -> Result<Top, serde_json::Error> {
    let top = TopSeed { state }.deserialize(&mut de)?;
    de.end()?;
    Ok(top)
}

fn stopped<E: de::Error>() -> E {
    E::custom("output closed")
}

impl<'de> DeserializeSeed<'de> for TopSeed<'_, '_, '_> {
    type Value = Top;
    fn deserialize<D: de::Deserializer<'de>>(self, d: D) -> Result<Top, D::Error> {
        d.deserialize_any(self)
    }
}

macro_rules! whole {
    ($name:ident, $t:ty) => {
        fn $name<E: de::Error>(self, v: $t) -> Result<Top, E> {
            Ok(Top::Whole(Value::from(v)))
        }
    };
}

impl<'de> Visitor<'de> for TopSeed<'_, '_, '_> {
    type Value = Top;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("a GeoJSON object")
    }

    whole!(visit_bool, bool);
    whole!(visit_i64, i64);
    whole!(visit_u64, u64);
    whole!(visit_f64, f64);
    whole!(visit_str, &str);
    whole!(visit_string, String);

    fn visit_unit<E: de::Error>(self) -> Result<Top, E> {
        Ok(Top::Whole(Value::Null))
    }

    fn visit_seq<A: SeqAccess<'de>>(self, seq: A) -> Result<Top, A::Error> {
        Value::deserialize(de::value::SeqAccessDeserializer::new(seq)).map(Top::Whole)
    }

    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Top, A::Error> {
        let mut before = Map::new();
        let mut after = Map::new();
        let mut streamed = false;
        while let Some(key) = map.next_key::<String>()? {
            let may_be_collection = before
                .get("type")
                .is_none_or(|t| t.as_str() == Some("FeatureCollection"));
            if key == "features" && !streamed && may_be_collection {
                let mut head = before.clone();
                head.remove("type");
                self.state
                    .emit(Unit::Members(head))
                    .map_err(|_| stopped::<A::Error>())?;
                map.next_value_seed(FeaturesSeed {
                    state: &mut *self.state,
                })?;
                streamed = true;
            } else {
                let v: Value = map.next_value()?;
                if streamed {
                    after.insert(key, v);
                } else {
                    before.insert(key, v);
                }
            }
        }
        Ok(if streamed {
            Top::Collection { before, after }
        } else {
            Top::Whole(Value::Object(before))
        })
    }
}

/// The `features` array, handed on element by element.
struct FeaturesSeed<'a, 's, 'e> {
    state: &'a mut DocumentState<'s, 'e>,
}

impl<'de> DeserializeSeed<'de> for FeaturesSeed<'_, '_, '_> {
    type Value = ();
    fn deserialize<D: de::Deserializer<'de>>(self, d: D) -> Result<(), D::Error> {
        d.deserialize_seq(self)
    }
}

impl<'de> Visitor<'de> for FeaturesSeed<'_, '_, '_> {
    type Value = ();

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("an array of Features")
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<(), A::Error> {
        let mut i = 0usize;
        while let Some(raw) = seq.next_element::<Box<RawValue>>()? {
            let unit = Unit::Record(Record {
                at: Position {
                    input: self.state.index,
                    number: i + 1,
                    line: None,
                },
                body: Body::Feature {
                    raw,
                    pointer: format!("/features/{i}"),
                },
                bytes: 0,
            });
            self.state.emit(unit).map_err(|_| stopped::<A::Error>())?;
            i += 1;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn detect_str(s: &str) -> Format {
        let mut r = io::Cursor::new(s.as_bytes().to_vec());
        detect(&mut r).unwrap().0
    }

    #[test]
    fn formats_are_told_apart_from_the_start() {
        let f = r#"{"type":"Feature","properties":null,"geometry":null}"#;
        assert_eq!(detect_str(&format!("\x1e{f}\n\x1e{f}\n")), Format::Seq);
        assert_eq!(detect_str(&format!("  \n\x1e{f}\n")), Format::Seq);
        assert_eq!(detect_str(&format!("{f}\n{f}\n")), Format::Lines);
        assert_eq!(detect_str(&format!("{f}\n")), Format::Geojson);
        assert_eq!(
            detect_str("{\n  \"type\": \"FeatureCollection\",\n  \"features\": []\n}\n"),
            Format::Geojson
        );
        assert_eq!(
            detect_str(r#"{"type":"FeatureCollection","features":[]}"#),
            Format::Geojson
        );
        assert_eq!(detect_str(" \n "), Format::Lines);
        // Only an object's `type` counts; other JSON values on the first line are records.
        assert_eq!(detect_str("[\"FeatureCollection\"]\n[1]\n"), Format::Lines);
        assert_eq!(detect_str("{\"type\": 5}\n{}\n"), Format::Lines);
        assert_eq!(
            detect_str("{\"type\": \"FeatureCollection\"\n"),
            Format::Geojson
        );
        assert_eq!(
            probe_type(b" {\"a\": [1, {\"type\": 2}], \"type\": \"X\"}"),
            Some(Some("X".into()))
        );
        assert_eq!(probe_type(b"[1, 2]"), Some(None));
        assert_eq!(probe_type(b"{\"type\": "), None);
    }

    /// The units read from `text`, streamed and read whole first: both ways must agree.
    fn collect(text: &str, format: Format) -> (Vec<Unit>, Result<(), ReadError>) {
        let read = |whole: Option<usize>| {
            let opened = Opened {
                index: 0,
                format,
                reader: Box::new(io::Cursor::new(text.as_bytes().to_vec())),
                count: Arc::new(AtomicU64::new(0)),
                whole,
                source: None,
                notes: Vec::new(),
            };
            let mut units = Vec::new();
            let r = opened.read("t", &mut |u, _| {
                units.push(u);
                Ok(())
            });
            (units, r)
        };
        let streamed = read(None);
        // Read whole; and a file that grew after it was opened (streamed on from what was read).
        for whole in [Some(text.len()), Some(text.len() / 2)] {
            assert_eq!(format!("{streamed:?}"), format!("{:?}", read(whole)));
        }
        streamed
    }

    #[test]
    fn a_collection_is_handed_on_feature_by_feature_with_its_members() {
        let doc =
            r#"{"name":"n","type":"FeatureCollection","features":[{"a":1},{"b":2}],"crs":{"x":1}}"#;
        let (units, r) = collect(doc, Format::Geojson);
        r.unwrap();
        assert_eq!(units.len(), 4);
        assert!(matches!(&units[0], Unit::Members(m) if m.len() == 1 && m["name"] == "n"));
        match &units[2] {
            Unit::Record(Record {
                at,
                body: Body::Feature { raw, pointer },
                ..
            }) => {
                assert_eq!((at.number, pointer.as_str()), (2, "/features/1"));
                assert_eq!(raw.get(), r#"{"b":2}"#);
            }
            other => panic!("{other:?}"),
        }
        assert!(matches!(&units[3], Unit::Members(m) if m.len() == 1 && m["crs"]["x"] == 1));
    }

    #[test]
    fn other_documents_are_one_record_and_bad_json_is_fatal() {
        let (units, r) = collect(r#"[1, 2]"#, Format::Geojson);
        r.unwrap();
        assert!(
            matches!(&units[0], Unit::Record(Record { body: Body::Document(v), .. }) if v.is_array())
        );
        let (_, r) = collect(
            r#"{"type":"FeatureCollection","features":[{"a":1},"#,
            Format::Geojson,
        );
        assert!(matches!(r, Err(ReadError::Fatal(m)) if m.contains("EOF")));
        let (_, r) = collect("{\"a\":1}\n{\"b\":2}\n", Format::Geojson);
        assert!(matches!(r, Err(ReadError::Fatal(m)) if m.contains("--format lines")));
        // A Feature may have a foreign member "features"; once "type" says so, it is kept whole.
        let (units, r) = collect(r#"{"type":"Feature","features":[1]}"#, Format::Geojson);
        r.unwrap();
        assert!(
            matches!(&units[..], [Unit::Record(Record { body: Body::Document(v), .. })] if v["features"][0] == 1)
        );
        let (_, r) = collect(r#"{"features":[],"type":"Feature"}"#, Format::Geojson);
        assert!(
            matches!(r, Err(ReadError::Fatal(m)) if m.contains("expected \"FeatureCollection\""))
        );
    }

    #[test]
    fn sequences_split_into_numbered_texts() {
        let (units, r) = collect(
            "\x1e{\"a\":1}\n\x1e{\"a\":\n2}\n\x1e\n\x1e{bad\n",
            Format::Seq,
        );
        r.unwrap();
        let texts: Vec<(usize, String)> = units
            .iter()
            .map(|u| match u {
                Unit::Record(Record {
                    at,
                    body: Body::Text(t),
                    ..
                }) => (at.number, String::from_utf8(t.clone()).unwrap()),
                other => panic!("{other:?}"),
            })
            .collect();
        assert_eq!(
            texts,
            vec![
                (1, "{\"a\":1}".to_string()),
                (2, "{\"a\":\n2}".to_string()),
                (3, "{bad".to_string())
            ]
        );
        let (units, _) = collect("{\"a\":1}\n\n{\"a\":2}\r\n", Format::Lines);
        let lines: Vec<Option<usize>> = units
            .iter()
            .map(|u| match u {
                Unit::Record(r) => r.at.line,
                _ => None,
            })
            .collect();
        assert_eq!(lines, vec![Some(1), Some(3)]);
    }

    /// Hands out one byte per read, as a slow pipe may.
    struct Trickle(Vec<u8>, usize);

    impl Read for Trickle {
        fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
            if self.1 == self.0.len() || buf.is_empty() {
                return Ok(0);
            }
            buf[0] = self.0[self.1];
            self.1 += 1;
            Ok(1)
        }
    }

    #[test]
    fn a_leading_byte_order_mark_is_dropped_and_nothing_else() {
        let read = |bytes: &[u8], trickle: bool| {
            let mut out = Vec::new();
            if trickle {
                SkipBom::new(Trickle(bytes.to_vec(), 0))
                    .read_to_end(&mut out)
                    .unwrap();
            } else {
                SkipBom::new(bytes).read_to_end(&mut out).unwrap();
            }
            out
        };
        for trickle in [false, true] {
            assert_eq!(read(b"\xef\xbb\xbf{\"a\":1}", trickle), b"{\"a\":1}");
            assert_eq!(read(b"\xef\xbb\xbf", trickle), b"");
            // Only one, only at the start; short inputs come back whole.
            assert_eq!(
                read(b"\xef\xbb\xbf\xef\xbb\xbf{}", trickle),
                b"\xef\xbb\xbf{}"
            );
            assert_eq!(read(b"{}\xef\xbb\xbf", trickle), b"{}\xef\xbb\xbf");
            assert_eq!(read(b"\xef\xbb{}", trickle), b"\xef\xbb{}");
            assert_eq!(read(b"{}", trickle), b"{}");
            assert_eq!(read(b"", trickle), b"");
        }
        // The format probe sees the input without it.
        let mut r = BufReader::new(SkipBom::new(
            &b"\xef\xbb\xbf\x1e{\"type\":\"Feature\"}\n"[..],
        ));
        assert_eq!(detect(&mut r).unwrap().0, Format::Seq);
    }
}
