//! Progress on a terminal: features done, points per second and the ETA, on one line.

use crate::cli::batch::pipeline::{Progress, Totals};
use std::io;
use std::io::Write;
use std::time::Instant;

/// Progress on a terminal: one line, rewritten in place.
pub(super) struct TerminalProgress {
    pub(super) enabled: bool,
    pub(super) shown: bool,
    pub(super) total_bytes: Option<u64>,
    pub(super) started: Instant,
}

impl TerminalProgress {
    pub(super) fn new(
        enabled: bool,
        total_bytes: Option<u64>,
        started: Instant,
    ) -> TerminalProgress {
        TerminalProgress {
            enabled,
            shown: false,
            total_bytes,
            started,
        }
    }
}

/// `1:05` or `1:02:05`.
pub(super) fn clock(seconds: f64) -> String {
    let s = seconds.max(0.0).round() as u64;
    if s >= 3600 {
        format!("{}:{:02}:{:02}", s / 3600, s / 60 % 60, s % 60)
    } else {
        format!("{}:{:02}", s / 60, s % 60)
    }
}

/// The progress line: features, points per second and, when the input size is known, the
/// share done and the ETA.
pub(super) fn progress_line(
    totals: &Totals,
    bytes: u64,
    total_bytes: Option<u64>,
    elapsed_s: f64,
) -> String {
    let s = &totals.stats;
    let points = if s.input_points > 0 {
        s.input_points
    } else {
        s.output_points
    };
    let rate = points as f64 / elapsed_s.max(1e-9);
    let mut line = format!(
        "{} features, {} failed, {} points, {:.0} points/s",
        totals.features, totals.failed, points, rate
    );
    if let Some(total) = total_bytes.filter(|t| *t > 0) {
        let done = (bytes as f64 / total as f64).min(1.0);
        line.push_str(&format!(", {:.0} %", 100.0 * done));
        if done > 0.0 {
            let eta = elapsed_s * (1.0 - done) / done;
            line.push_str(&format!(", ETA {}", clock(eta)));
        }
    }
    line
}

impl Progress for TerminalProgress {
    fn update(&mut self, totals: &Totals, bytes: u64) {
        if !self.enabled {
            return;
        }
        let line = progress_line(
            totals,
            bytes,
            self.total_bytes,
            self.started.elapsed().as_secs_f64(),
        );
        let _ = write!(io::stderr(), "\r\x1b[K{line}");
        self.shown = true;
    }

    fn clear(&mut self) {
        if self.shown {
            let _ = write!(io::stderr(), "\r\x1b[K");
            self.shown = false;
        }
    }
}
