//! `spherefit fit --topology shared`: the input read whole and fitted as one polygon coverage
//! ([`crate::earth::coverage`]), written as GeoJSON or (`--output-format topojson`) TopoJSON.

use crate::cli::batch::args::BatchArgs;
use crate::cli::batch::input::Format;
use crate::cli::batch::stderr_line;
use crate::cli::Failure;
use crate::earth::coverage::{fit_coverage, Phases};
use crate::earth::features::Document;
use crate::earth::job::Job;
use crate::earth::job::{OutputFormat, Topology};
use clap::{Args, ValueEnum};
use std::io::{self, Read, Write};
use std::time::Instant;

/// How features relate (query parameter `topology`).
#[derive(Debug, Args)]
#[command(next_help_heading = "Topology")]
pub(crate) struct TopologyArgs {
    /// per-feature: every line and ring on its own; shared: the polygons of the input are one
    /// coverage, each border shared by neighbours fitted once (needs --tolerance-m; the input
    /// is read whole, one GeoJSON document; --output-format topojson writes TopoJSON)
    #[arg(long, value_name = "TOPOLOGY", default_value = "per-feature", value_parser = parse_topology)]
    pub topology: Topology,
}

fn parse_topology(s: &str) -> Result<Topology, String> {
    s.parse()
        .map_err(|_| format!("{s:?}: use per-feature or shared"))
}

impl Format {
    /// The output format an `--output-format` asks of the library: TopoJSON, or `None` for
    /// the default (GeoJSON; the sequence formats are the command line's own).
    pub(super) fn topology_format(self) -> Option<OutputFormat> {
        (self == Format::Topojson).then_some(OutputFormat::TopoJson)
    }
}

/// `--format` names a format that can be read.
pub(super) fn check_input_format(batch: &BatchArgs) -> Result<(), Failure> {
    let _ = batch;
    Ok(())
}

/// The input of a coverage as one FeatureCollection, when it is a file of
/// [`crate::formats`] (every layer's features, in order); `None` for GeoJSON.
fn read_file_format(
    batch: &BatchArgs,
    path: &std::path::Path,
    name: &str,
) -> Result<Option<Vec<u8>>, Failure> {
    let input = super::input::Input {
        name: name.to_string(),
        path: Some(path.to_path_buf()),
        size: None,
    };
    let kind = match batch.format.kind() {
        Some(k) => k,
        None if batch.format != Format::Auto => return Ok(None),
        None => {
            let mut head = Vec::with_capacity(1024);
            std::fs::File::open(path)
                .and_then(|f| f.take(1024).read_to_end(&mut head))
                .map_err(|e| Failure::input(format!("{name}: cannot open: {e}")))?;
            match crate::formats::Kind::detect(Some(path), &head) {
                Some(k) => k,
                None => return Ok(None),
            }
        }
    };
    let options = crate::formats::ReadOptions {
        layer: batch.layer.clone(),
    };
    let source = crate::formats::open(path, &input.name, kind, &options)
        .map_err(|e| Failure::input(e.to_string()))?;
    let mut features = Vec::new();
    for layer in source.layers {
        if !layer.crs.is_lonlat() && !batch.quiet {
            stderr_line(&format!(
                "spherefit: {name}: layer {:?}: coordinates in {} transformed to lon/lat (EPSG:4326)",
                layer.name, layer.crs.name
            ));
        }
        for f in layer.features {
            features.push(f.map_err(|e| Failure::input(e.to_string()))?);
        }
    }
    let doc = serde_json::json!({"type": "FeatureCollection", "features": features});
    serde_json::to_vec(&doc)
        .map(Some)
        .map_err(|e| Failure::input(format!("{name}: {e}")))
}

/// Runs the coverage fit of `job` (whose topology is shared).
pub(super) fn fit(job: Job, batch: &BatchArgs) -> Result<(), Failure> {
    let started = Instant::now();
    let mut phases = Phases::new();
    check_input_format(batch)?;
    if matches!(batch.output_format, Format::Seq | Format::Lines) {
        let name = batch
            .output_format
            .to_possible_value()
            .map_or("?".into(), |v| v.get_name().to_string());
        return Err(Failure::input(format!(
            "--output-format {name}: --topology shared writes one document: geojson or topojson"
        )));
    }
    let format = job.format;
    super::set_threads(batch.threads)?;
    if batch.inputs.len() > 1 {
        return Err(Failure::input(
            "--topology shared fits one coverage: give one input (merge the files first)",
        ));
    }
    let (name, bytes) = match batch.inputs.first().filter(|p| p.as_os_str() != "-") {
        Some(p) => {
            let name = p.display().to_string();
            let bytes = match read_file_format(batch, p, &name)? {
                Some(b) => b,
                None => {
                    std::fs::read(p).map_err(|e| Failure::input(format!("{}: {e}", p.display())))?
                }
            };
            (name, bytes)
        }
        None => {
            let mut b = Vec::new();
            io::stdin()
                .read_to_end(&mut b)
                .map_err(|e| Failure::input(format!("stdin: {e}")))?;
            ("stdin".to_string(), b)
        }
    };
    phases.lap("read input");
    let text = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(&bytes);
    let value = crate::earth::features::parse_json(text)
        .map_err(|e| Failure::input(format!("{name}: not a GeoJSON document: {e}")))?;
    phases.lap("parse JSON");
    let fail = |e: crate::earth::EarthError| Failure {
        status: 1,
        message: format!("{name}: {e}"),
    };
    let doc = Document::parse(value, false).map_err(fail)?;
    phases.lap("document");
    let coverage = fit_coverage(doc, &job).map_err(fail)?;
    phases.lap_with(&coverage.phases, "(rest of the fit)");
    let report = coverage.report.clone();
    let text = match format {
        OutputFormat::TopoJson => {
            let topology = crate::earth::coverage::topojson::to_topology(
                coverage,
                job.output.precision,
                job.carry,
            );
            let bytes = crate::earth::coverage::topojson::to_bytes(&topology);
            // Freed on the pool while the bytes are written.
            rayon::spawn(move || drop(topology));
            bytes
        }
        OutputFormat::GeoJson => serde_json::to_vec(&coverage.into_feature_collection(job.carry))
            .map_err(|e| Failure::input(e.to_string()))?,
    };
    phases.lap("assemble output");
    let out_path = batch.output.as_ref().filter(|p| p.as_os_str() != "-");
    let written = match out_path {
        Some(p) => std::fs::write(p, [&text[..], b"\n"].concat())
            .map_err(|e| format!("{}: cannot write: {e}", p.display())),
        None => {
            let mut o = io::stdout().lock();
            o.write_all(&text)
                .and_then(|_| o.write_all(b"\n"))
                .map_err(|e| format!("stdout: cannot write: {e}"))
        }
    };
    phases.lap("write output");
    written.map_err(Failure::input)?;
    let seconds = started.elapsed().as_secs_f64();
    if !batch.quiet {
        stderr_line(&format!(
            "spherefit fit --topology shared: {} polygon features, {} arcs ({} shared), {} points in, {} numbers stored (arcs once), compression {}, two-way error <= {} m, tolerance met: {}, {seconds:.2} s",
            report["polygon_features"],
            report["arc_count"],
            report["shared_arcs"],
            report["input_points"],
            report["stored_numbers"],
            report["compression_ratio"],
            report["two_way_distance_m"],
            report["tolerance_met"],
        ));
    }
    if let Some(p) = &batch.stats {
        let mut r = report;
        r["seconds"] = serde_json::json!(seconds);
        r["phases"] = phases.to_json();
        let line = r.to_string();
        if p.as_os_str() == "-" {
            stderr_line(&line);
        } else {
            std::fs::write(p, format!("{line}\n"))
                .map_err(|e| Failure::input(format!("--stats: {}: {e}", p.display())))?;
        }
    }
    Ok(())
}
