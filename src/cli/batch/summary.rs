//! The end-of-run summary, as text and JSON (`--stats`).

use crate::cli::batch::pipeline::Totals;
use serde_json::json;

/// The end-of-run summary, as text and JSON.
pub(super) struct Summary<'a> {
    pub(super) command: &'static str,
    pub(super) totals: &'a Totals,
    pub(super) seconds: f64,
    pub(super) threads: usize,
}

impl Summary<'_> {
    /// Numbers in the input (lon and lat of each point) per number stored in the curves.
    pub(super) fn compression_ratio(&self) -> Option<f64> {
        let s = &self.totals.stats;
        (s.stored_numbers > 0 && s.input_points > 0)
            .then(|| 2.0 * s.input_points as f64 / s.stored_numbers as f64)
    }

    pub(super) fn points_per_second(&self) -> f64 {
        let s = &self.totals.stats;
        let points = if s.input_points > 0 {
            s.input_points
        } else {
            s.output_points
        };
        points as f64 / self.seconds.max(1e-9)
    }

    /// The largest max error of a curve and where (evaluation measures no error).
    pub(super) fn worst(&self) -> Option<&(f64, String)> {
        self.totals
            .worst
            .as_ref()
            .filter(|_| self.command != "evaluate")
    }

    pub(super) fn text(&self) -> String {
        let t = self.totals;
        let s = &t.stats;
        let mut line = format!(
            "spherefit {}: {} features written ({} with curves), {} failed, in {:.2} s ({:.0} points/s, {} threads)\n  {} points in, {} curves, {} numbers stored",
            self.command,
            t.features,
            t.with_curves,
            t.failed,
            self.seconds,
            self.points_per_second(),
            self.threads,
            s.input_points,
            s.curves,
            s.stored_numbers,
        );
        if let Some(r) = self.compression_ratio() {
            line.push_str(&format!(" (compression {r:.2}:1)"));
        }
        line.push_str(&format!(", {} points out", s.output_points));
        if let Some((e, at)) = self.worst() {
            line.push_str(&format!(", worst max error {e:.3} m ({at})"));
        }
        line
    }

    pub(super) fn warning(&self) -> Option<String> {
        let t = self.totals;
        if t.failed > 0 || t.with_curves > 0 {
            return None;
        }
        Some(if t.records == 0 {
            "the input holds no records".into()
        } else if self.command == "evaluate" {
            "no feature carries properties.fit or properties.interpolation (as written by spherefit fit and interpolate): everything passed through unchanged".into()
        } else {
            "the input holds no LineString, MultiLineString, Polygon or MultiPolygon with coordinates: everything passed through unchanged".into()
        })
    }

    pub(super) fn json(&self) -> serde_json::Value {
        let t = self.totals;
        let s = &t.stats;
        json!({
            "command": self.command,
            "records": t.records,
            "features": t.features,
            "features_with_curves": t.with_curves,
            "failed": t.failed,
            "curves": s.curves,
            "input_points": s.input_points,
            "output_points": s.output_points,
            "stored_numbers": s.stored_numbers,
            "compression_ratio": self.compression_ratio(),
            "max_error_m": self.worst().map(|w| w.0),
            "max_error_at": self.worst().map(|w| w.1.clone()),
            "seconds": self.seconds,
            "points_per_second": self.points_per_second(),
            "threads": self.threads,
            "output_closed": t.output_closed,
        })
    }
}
