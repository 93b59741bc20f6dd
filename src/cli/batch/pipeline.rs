//! The streaming pipeline: one reader thread, the rayon pool, one writer (the calling thread).
//!
//! ```text
//! reader thread --(window)--> rayon::spawn(parse + process + serialise) --channel--> writer
//! ```
//!
//! * **Memory bound.** The reader numbers each unit and must take a place in the [`Window`]
//!   before handing it on; the writer gives the place back once the unit's output is written.
//!   So at most `64 x threads` units (and about [`WINDOW_BYTES`] of their input) are
//!   anywhere between reading and writing: queued, being processed, or finished and waiting
//!   for an earlier one. Memory does not grow with the input; only the largest single record
//!   matters (one record always gets in, however large).
//! * **Order.** Workers finish in any order; the writer keeps finished units in a map keyed by
//!   their number and writes them strictly in input order, so output records and error
//!   messages come in input order.
//! * **Stopping.** When the output closes (a broken pipe) or fails, the writer closes the
//!   window: the reader's next wait fails and it stops reading, and queued workers skip their
//!   work.

use crate::cli::batch::input::{Body, Format, Input, Opened, Position, ReadError, Unit, RS};
use crate::earth::error::{EarthError, Problem};
use crate::earth::features::{process_feature, Document, FeatureStats, ProcessedFeature};
use crate::earth::job::Job;
use crate::formats::write::FeatureWriter;
use crate::formats::ReadOptions;
use serde_json::{Map, Value};
use std::collections::BTreeMap;
use std::io::{self, Write};
use std::sync::mpsc;
use std::sync::{Arc, Condvar, Mutex};
use std::time::{Duration, Instant};

/// Input bytes allowed in flight at once (one record always gets in). 64 MiB keeps the peak
/// bounded even when output is many times larger than input.
pub const WINDOW_BYTES: usize = 64 << 20;

/// Units in flight per worker thread: enough that a slow feature does not starve the pool
/// while the writer waits for it. At 16 the second worker of two sat idle for about 0.1 s
/// of the 10m land outlines (Afro-Eurasia's last, serial steps holding up the writer); 64
/// ran 4.6 % faster there (8 alternated runs), with the same peak memory.
const UNITS_PER_THREAD: usize = 64;

/// Places for units between the reader and the writer.
pub struct Window {
    state: Mutex<WindowState>,
    changed: Condvar,
    max_units: usize,
    max_bytes: usize,
}

#[derive(Default)]
struct WindowState {
    units: usize,
    bytes: usize,
    closed: bool,
}

impl Window {
    /// A window for `threads` workers.
    pub fn new(threads: usize) -> Window {
        Window {
            state: Mutex::new(WindowState::default()),
            changed: Condvar::new(),
            max_units: UNITS_PER_THREAD * threads.max(1),
            max_bytes: WINDOW_BYTES,
        }
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, WindowState> {
        self.state.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Waits for a place for a unit of `bytes`; `Err` once the window is closed.
    pub fn enter(&self, bytes: usize) -> Result<(), ()> {
        let mut s = self.lock();
        while !s.closed
            && s.units > 0
            && (s.units >= self.max_units || s.bytes + bytes > self.max_bytes)
        {
            s = self.changed.wait(s).unwrap_or_else(|p| p.into_inner());
        }
        if s.closed {
            return Err(());
        }
        s.units += 1;
        s.bytes += bytes;
        Ok(())
    }

    /// Gives back the place of a unit of `bytes`.
    pub fn leave(&self, bytes: usize) {
        let mut s = self.lock();
        s.units -= 1;
        s.bytes -= bytes;
        self.changed.notify_all();
    }

    /// Closes the window: waiting and later [`Window::enter`] calls fail.
    pub fn close(&self) {
        self.lock().closed = true;
        self.changed.notify_all();
    }

    fn is_closed(&self) -> bool {
        self.lock().closed
    }
}

/// What a worker made of one record.
#[derive(Debug, Default)]
pub struct Processed {
    /// Output features, serialised.
    pub features: Vec<Vec<u8>>,
    /// Counters over the record's features.
    pub stats: FeatureStats,
    /// Features with at least one curve.
    pub with_curves: usize,
    /// Messages for the features that failed (one each), with the record's position.
    pub errors: Vec<String>,
    /// Of those, the features whose compact curve did not decode (corrupt input).
    pub corrupt: usize,
    /// Largest max error of a feature and its label.
    pub worst: Option<(f64, String)>,
    /// The fit warnings of the record's features (`properties.fit.warnings`, and those of its
    /// parts), with the record's position.
    pub warnings: Vec<String>,
}

/// A record's label in messages: `in.geojsons: record 3` (`(line 5)` for newline-delimited).
pub fn label(names: &[String], at: &Position) -> String {
    let name = &names[at.input];
    match at.line {
        Some(l) if l != at.number => format!("{name}: record {} (line {l})", at.number),
        _ => format!("{name}: record {}", at.number),
    }
}

/// Runs the processing of one feature so that nothing in it, not even a panic (a bug), can take
/// the records after it down: a panic is reported as that feature's error.
fn guarded(
    f: impl FnOnce() -> Result<ProcessedFeature, EarthError>,
) -> Result<ProcessedFeature, (String, bool)> {
    match std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)) {
        Ok(r) => r.map_err(|e| {
            let corrupt = matches!(e.problem, Problem::CorruptCompactCurve(_));
            (e.to_string(), corrupt)
        }),
        Err(panic) => {
            let what = panic
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| panic.downcast_ref::<String>().cloned())
                .unwrap_or_default();
            Err((
                format!(
                    "internal error while processing this feature (a bug, please report it): {what}"
                ),
                false,
            ))
        }
    }
}

/// Parses (when needed), processes and serialises one record.
pub fn process(
    body: Body,
    at: &Position,
    names: &[String],
    job: &Job,
    allow_spline: bool,
) -> Processed {
    let mut out = Processed::default();
    let label = label(names, at);
    match body {
        Body::Text(bytes) => match serde_json::from_slice::<Value>(&bytes) {
            Ok(v) => out.document(v, &label, job, allow_spline),
            Err(e) => out.errors.push(format!("{label}: invalid JSON: {e}")),
        },
        Body::Document(v) => out.document(v, &label, job, allow_spline),
        Body::Feature { raw, pointer } => match serde_json::from_str::<Value>(raw.get()) {
            Ok(value) => out.add(guarded(|| process_feature(&value, &pointer, job)), &label),
            // The reader checked the syntax; what is left is a number out of range.
            Err(e) => out.errors.push(format!(
                "{label}: invalid JSON at {pointer}: {e} (in the feature's text)"
            )),
        },
    }
    out
}

impl Processed {
    /// Copies the fit warnings of a serialised feature (its own and its parts') into
    /// `warnings`.
    fn collect_warnings(&mut self, bytes: &[u8], label: &str) {
        let Ok(v) = serde_json::from_slice::<Value>(bytes) else {
            return;
        };
        let fit = &v["properties"]["fit"];
        let parts = fit["parts"].as_array().into_iter().flatten();
        for f in std::iter::once(fit).chain(parts) {
            for w in f["warnings"].as_array().into_iter().flatten() {
                if let Some(w) = w.as_str() {
                    self.warnings.push(format!("{label}: warning: {w}"));
                }
            }
        }
    }

    /// Processes every feature of a parsed record.
    fn document(&mut self, v: Value, label: &str, job: &Job, allow_spline: bool) {
        match Document::parse(v, allow_spline) {
            Ok(doc) => {
                for slot in &doc.slots {
                    self.add(guarded(|| slot.process(job)), label);
                }
            }
            Err(e) => self.errors.push(format!("{label}: {e}")),
        }
    }

    /// Adds the result of one feature.
    fn add(&mut self, r: Result<ProcessedFeature, (String, bool)>, label: &str) {
        let p = match r {
            Ok(p) => p,
            Err((e, corrupt)) => {
                self.corrupt += usize::from(corrupt);
                return self.errors.push(format!("{label}: {e}"));
            }
        };
        match p.feature.to_json_vec() {
            Ok(bytes) => {
                if p.feature.has_key("warnings") {
                    self.collect_warnings(&bytes, label);
                }
                self.features.push(bytes)
            }
            Err(e) => return self.errors.push(format!("{label}: cannot serialise: {e}")),
        }
        if p.stats.curves > 0 {
            self.with_curves += 1;
            if self
                .worst
                .as_ref()
                .is_none_or(|(e, _)| p.stats.max_error_m > *e)
            {
                self.worst = Some((p.stats.max_error_m, label.to_string()));
            }
        }
        self.stats.merge(&p.stats);
    }
}

/// Frames serialised features in the output format.
pub struct Sink<W: Write> {
    out: W,
    format: Format,
    started: bool,
    head: Map<String, Value>,
    tail: Map<String, Value>,
    /// A file of [`crate::formats`] (GeoPackage, FlatGeobuf, Shapefile, GPX) written instead
    /// of `out`.
    file: Option<FeatureWriter>,
    /// What the file's writer reported (fields renamed), once finished.
    pub notes: Vec<String>,
}

impl<W: Write> Sink<W> {
    /// A sink writing `format` (not [`Format::Auto`]) to `out`.
    pub fn new(out: W, format: Format) -> Sink<W> {
        Sink {
            out,
            format,
            started: false,
            head: Map::new(),
            tail: Map::new(),
            file: None,
            notes: Vec::new(),
        }
    }

    /// A sink writing the features to `file` (`out` is left unused).
    pub fn to_file(out: W, format: Format, file: FeatureWriter) -> Sink<W> {
        let mut s = Sink::new(out, format);
        s.file = Some(file);
        s
    }

    /// Foreign members of an input collection, kept when writing a FeatureCollection (the
    /// first value of a name wins; `bbox` is dropped, as the service drops it).
    pub fn members(&mut self, members: Map<String, Value>) {
        for (k, v) in members {
            if k == "bbox" || k == "type" || k == "features" || self.head.contains_key(&k) {
                continue;
            }
            let target = if self.started {
                &mut self.tail
            } else {
                &mut self.head
            };
            target.entry(k).or_insert(v);
        }
    }

    fn write_members(&mut self, members: &Map<String, Value>, after: bool) -> io::Result<()> {
        for (k, v) in members {
            if after {
                self.out.write_all(b",")?;
            }
            serde_json::to_writer(&mut self.out, k)?;
            self.out.write_all(b":")?;
            serde_json::to_writer(&mut self.out, v)?;
            if !after {
                self.out.write_all(b",")?;
            }
        }
        Ok(())
    }

    fn start(&mut self) -> io::Result<()> {
        self.started = true;
        self.out.write_all(b"{\"type\":\"FeatureCollection\",")?;
        let head = std::mem::take(&mut self.head);
        self.write_members(&head, false)?;
        self.head = head;
        self.out.write_all(b"\"features\":[\n")
    }

    /// Writes one serialised feature.
    pub fn feature(&mut self, json: &[u8]) -> io::Result<()> {
        if let Some(f) = &mut self.file {
            return f.feature(json);
        }
        match self.format {
            Format::Seq => {
                self.out.write_all(&[RS])?;
                self.out.write_all(json)?;
                self.out.write_all(b"\n")
            }
            Format::Geojson
            | Format::Auto
            | Format::Topojson
            | Format::Shapefile
            | Format::Gpkg
            | Format::Fgb
            | Format::Gpx => {
                if self.started {
                    self.out.write_all(b",\n")?;
                } else {
                    self.start()?;
                }
                self.out.write_all(json)
            }
            Format::Lines => {
                self.out.write_all(json)?;
                self.out.write_all(b"\n")
            }
        }
    }

    /// Ends the output (closes the FeatureCollection) and flushes.
    pub fn finish(&mut self) -> io::Result<()> {
        if let Some(f) = self.file.take() {
            self.notes = f.finish().map_err(io::Error::other)?;
            return Ok(());
        }
        if matches!(self.format, Format::Geojson | Format::Auto) {
            if !self.started {
                self.start()?;
                self.out.write_all(b"]")?;
            } else {
                self.out.write_all(b"\n]")?;
            }
            let tail = std::mem::take(&mut self.tail);
            self.write_members(&tail, true)?;
            self.out.write_all(b"}\n")?;
        }
        self.out.flush()
    }

    /// Flushes what is buffered.
    pub fn flush(&mut self) -> io::Result<()> {
        self.out.flush()
    }
}

/// Totals of a run.
#[derive(Debug, Default)]
pub struct Totals {
    /// Input records read (for a FeatureCollection, its features).
    pub records: usize,
    /// Features written.
    pub features: usize,
    /// Features written that had curves.
    pub with_curves: usize,
    /// Features (or records) that failed.
    pub failed: usize,
    /// Of those, the features whose compact curve did not decode.
    pub corrupt: usize,
    pub stats: FeatureStats,
    /// Largest max error and where.
    pub worst: Option<(f64, String)>,
    /// The output was closed by its reader (a broken pipe): the run stopped early.
    pub output_closed: bool,
}

/// How the writer reports progress.
pub trait Progress {
    /// Called after each written unit and a few times a second while waiting; `bytes` is the
    /// input read up to the last written unit.
    fn update(&mut self, totals: &Totals, bytes: u64);
    /// Called before a message is printed and at the end, to clear the line.
    fn clear(&mut self);
}

/// What the writer receives for each numbered unit.
enum Done {
    Record {
        processed: Processed,
        bytes: usize,
        offset: u64,
    },
    Members(Map<String, Value>),
}

/// Everything [`run`] needs besides the inputs.
#[derive(Clone)]
pub struct Settings {
    pub job: Arc<Job>,
    pub allow_spline: bool,
    /// Input names, by index.
    pub names: Arc<Vec<String>>,
    /// Forced input format ([`Format::Auto`] to detect each input).
    pub input_format: Format,
    /// How files of [`crate::formats`] are read (`--layer`).
    pub read_options: ReadOptions,
    /// `--quiet`: no notes on stderr.
    pub quiet: bool,
}

/// Why [`run`] ended badly.
#[derive(Debug)]
pub enum Fatal {
    /// An input could not be read on (the message names it).
    Input(String),
    /// The output could not be written.
    Output(io::Error),
}

/// Runs the pipeline over `first` (already opened) and the `rest` of the inputs, writing to
/// `sink`. Per-record errors go to `errors` in input order. Returns the totals and the first
/// fatal error, if any (records before it are written; after a fatal error the output is
/// not closed, so that it does not look complete).
pub fn run<W: Write>(
    first: Opened,
    rest: Vec<(usize, Input)>,
    sink: &mut Sink<W>,
    settings: &Settings,
    progress: &mut dyn Progress,
    errors: &mut dyn FnMut(&str),
) -> (Totals, Option<Fatal>) {
    let window = Arc::new(Window::new(rayon::current_num_threads()));
    let (tx, rx) = mpsc::channel::<(u64, Done)>();
    let reader = {
        let window = window.clone();
        let settings = settings.clone();
        std::thread::Builder::new()
            .name("spherefit-reader".into())
            .spawn(move || read_all(first, rest, &settings, &window, &tx))
    };
    let reader = match reader {
        Ok(r) => r,
        Err(e) => {
            return (
                Totals::default(),
                Some(Fatal::Input(format!("cannot start the reader: {e}"))),
            )
        }
    };

    let mut totals = Totals::default();
    let mut fatal = None;
    let mut pending: BTreeMap<u64, Done> = BTreeMap::new();
    let mut next = 0u64;
    let mut offset = 0u64;
    let tick = Duration::from_millis(200);
    let mut last_tick = Instant::now();
    'outer: loop {
        let (n, done) = match rx.try_recv() {
            Ok(x) => x,
            Err(mpsc::TryRecvError::Disconnected) => break,
            Err(mpsc::TryRecvError::Empty) => {
                // Nothing ready: let what is written so far reach the reader of the output.
                if let Err(e) = sink.flush() {
                    fatal = output_error(e, &mut totals);
                    break;
                }
                loop {
                    match rx.recv_timeout(tick) {
                        Ok(x) => break x,
                        Err(mpsc::RecvTimeoutError::Timeout) => {
                            progress.update(&totals, offset);
                            last_tick = Instant::now();
                        }
                        Err(mpsc::RecvTimeoutError::Disconnected) => break 'outer,
                    }
                }
            }
        };
        pending.insert(n, done);
        while let Some(done) = pending.remove(&next) {
            next += 1;
            match done {
                Done::Members(m) => {
                    sink.members(m);
                    window.leave(0);
                }
                Done::Record {
                    processed,
                    bytes,
                    offset: o,
                } => {
                    totals.records += 1;
                    offset = o;
                    if !processed.errors.is_empty() || !processed.warnings.is_empty() {
                        progress.clear();
                        for e in processed.errors.iter().chain(&processed.warnings) {
                            errors(e);
                        }
                    }
                    totals.failed += processed.errors.len();
                    totals.corrupt += processed.corrupt;
                    totals.with_curves += processed.with_curves;
                    totals.stats.merge(&processed.stats);
                    if let Some((e, at)) = processed.worst {
                        if totals.worst.as_ref().is_none_or(|(w, _)| e > *w) {
                            totals.worst = Some((e, at));
                        }
                    }
                    for f in &processed.features {
                        if let Err(e) = sink.feature(f) {
                            fatal = output_error(e, &mut totals);
                            break 'outer;
                        }
                        totals.features += 1;
                    }
                    window.leave(bytes);
                }
            }
        }
        if last_tick.elapsed() >= tick {
            progress.update(&totals, offset);
            last_tick = Instant::now();
        }
    }
    window.close();
    drop(rx);
    if fatal.is_some() || totals.output_closed {
        progress.clear();
        // The reader may be blocked reading (a terminal, a slow pipe): it stops at its next
        // record, or with the process; its errors no longer matter.
        return (totals, fatal);
    }
    // Every record arrived, so the reader has returned: its verdict comes before the closing
    // bracket, which is not written after a fatal input error (the output must not look
    // complete).
    let read = reader
        .join()
        .unwrap_or_else(|_| Err(ReadError::Fatal("the reader thread panicked".into())));
    if let Err(ReadError::Fatal(m)) = read {
        fatal = Some(Fatal::Input(m));
    } else if let Err(e) = sink.finish() {
        fatal = output_error(e, &mut totals);
    }
    progress.clear();
    (totals, fatal)
}

/// A broken pipe ends the run quietly; any other write error is fatal.
fn output_error(e: io::Error, totals: &mut Totals) -> Option<Fatal> {
    if e.kind() == io::ErrorKind::BrokenPipe {
        totals.output_closed = true;
        None
    } else {
        Some(Fatal::Output(e))
    }
}

/// The reader thread: opens the inputs in turn and hands every unit to the pool.
fn read_all(
    first: Opened,
    rest: Vec<(usize, Input)>,
    settings: &Settings,
    window: &Arc<Window>,
    tx: &mpsc::Sender<(u64, Done)>,
) -> Result<(), ReadError> {
    let Settings {
        job,
        allow_spline,
        names,
        input_format: forced,
        read_options,
        quiet,
    } = settings;
    let (allow_spline, forced) = (*allow_spline, *forced);
    let mut n = 0u64;
    let mut emit = |unit: Unit, read: u64, base: u64| -> Result<(), ()> {
        let bytes = match &unit {
            Unit::Record(r) => r.bytes,
            Unit::Members(_) => 0,
        };
        window.enter(bytes)?;
        let this = n;
        n += 1;
        match unit {
            Unit::Members(m) => tx.send((this, Done::Members(m))).map_err(|_| ()),
            Unit::Record(r) => {
                let (tx, job, names, window) =
                    (tx.clone(), job.clone(), names.clone(), window.clone());
                let offset = base + read;
                rayon::spawn(move || {
                    let processed = if window.is_closed() {
                        Processed::default()
                    } else {
                        process(r.body, &r.at, &names, &job, allow_spline)
                    };
                    let _ = tx.send((
                        this,
                        Done::Record {
                            processed,
                            bytes,
                            offset,
                        },
                    ));
                });
                Ok(())
            }
        }
    };
    let mut base = 0u64;
    let mut opened = first;
    let mut rest = rest.into_iter();
    loop {
        let counter = opened.counter();
        let name = names[opened.index].clone();
        let start = base;
        opened.read(&name, &mut |u, read| emit(u, read, start))?;
        base += counter.load(std::sync::atomic::Ordering::Relaxed);
        match rest.next() {
            None => return Ok(()),
            Some((index, input)) => {
                opened = super::input::open(&input, index, forced, read_options)
                    .map_err(ReadError::Fatal)?;
                if !quiet {
                    for n in &opened.notes {
                        super::stderr_line(&format!("spherefit: {n}"));
                    }
                }
            }
        }
    }
}
