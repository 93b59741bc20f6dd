//! Prometheus text exposition (`GET /metrics`): requests and errors by route and status,
//! request and fitting durations, points and curves processed, fitting slots in use.
//!
//! A few counters behind mutexes are all this needs; no metrics crate.

use std::collections::BTreeMap;
use std::fmt::Write;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;

/// Upper bounds of the duration histograms, seconds.
const BUCKETS_S: [f64; 14] = [
    0.001, 0.0025, 0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1.0, 2.5, 5.0, 10.0, 30.0,
];

#[derive(Clone, Debug, Default)]
struct Histogram {
    counts: [u64; BUCKETS_S.len()],
    count: u64,
    sum: f64,
}

impl Histogram {
    fn observe(&mut self, x: f64) {
        for (i, b) in BUCKETS_S.iter().enumerate() {
            if x <= *b {
                self.counts[i] += 1;
            }
        }
        self.count += 1;
        self.sum += x;
    }

    fn render(&self, out: &mut String, name: &str, labels: &str) {
        let sep = if labels.is_empty() { "" } else { "," };
        for (i, b) in BUCKETS_S.iter().enumerate() {
            let _ = writeln!(
                out,
                "{name}_bucket{{{labels}{sep}le=\"{b}\"}} {}",
                self.counts[i]
            );
        }
        let _ = writeln!(
            out,
            "{name}_bucket{{{labels}{sep}le=\"+Inf\"}} {}",
            self.count
        );
        let _ = writeln!(out, "{name}_sum{{{labels}}} {}", self.sum);
        let _ = writeln!(out, "{name}_count{{{labels}}} {}", self.count);
    }
}

/// The service's counters.
#[derive(Debug, Default)]
pub struct Metrics {
    /// (route, method, status) -> count.
    requests: Mutex<BTreeMap<(String, String, u16), u64>>,
    /// (route, status, problem type) -> count, for status >= 400.
    errors: Mutex<BTreeMap<(String, u16, String), u64>>,
    request_duration: Mutex<BTreeMap<String, Histogram>>,
    fit_duration: Mutex<BTreeMap<String, Histogram>>,
    points: Mutex<BTreeMap<String, u64>>,
    curves: Mutex<BTreeMap<String, u64>>,
    overload_rejections: AtomicU64,
    timeouts: AtomicU64,
    /// Requests holding a fitting slot now.
    pub fits_in_progress: AtomicU64,
    /// Requests waiting for a fitting slot now.
    pub fits_waiting: AtomicU64,
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    // A panic while holding one of these locks cannot leave a counter inconsistent.
    m.lock().unwrap_or_else(|p| p.into_inner())
}

/// Escapes a label value (backslash, quote, newline).
fn esc(s: &str) -> String {
    s.replace('\\', "\\\\")
        .replace('"', "\\\"")
        .replace('\n', "\\n")
}

/// The `method` label: one of the standard methods, or `other` (a label taken from the client
/// as is would let each made-up method add a series).
pub fn method_label(method: &str) -> &'static str {
    const KNOWN: [&str; 9] = [
        "GET", "HEAD", "POST", "PUT", "DELETE", "OPTIONS", "PATCH", "CONNECT", "TRACE",
    ];
    KNOWN
        .iter()
        .find(|m| **m == method)
        .copied()
        .unwrap_or("other")
}

impl Metrics {
    /// Records one finished request.
    pub fn record_request(
        &self,
        route: &str,
        method: &str,
        status: u16,
        problem: Option<&str>,
        seconds: f64,
    ) {
        *lock(&self.requests)
            .entry((route.to_string(), method_label(method).to_string(), status))
            .or_default() += 1;
        if status >= 400 {
            *lock(&self.errors)
                .entry((
                    route.to_string(),
                    status,
                    problem.unwrap_or("unknown").to_string(),
                ))
                .or_default() += 1;
        }
        if status == 503 {
            match problem {
                Some("overloaded") => self.overload_rejections.fetch_add(1, Ordering::Relaxed),
                _ => self.timeouts.fetch_add(1, Ordering::Relaxed),
            };
        }
        lock(&self.request_duration)
            .entry(route.to_string())
            .or_default()
            .observe(seconds);
    }

    /// Records the CPU work of one request: how long it took and how much it processed.
    pub fn record_fit(&self, route: &str, seconds: f64, points: usize, curves: usize) {
        lock(&self.fit_duration)
            .entry(route.to_string())
            .or_default()
            .observe(seconds);
        *lock(&self.points).entry(route.to_string()).or_default() += points as u64;
        *lock(&self.curves).entry(route.to_string()).or_default() += curves as u64;
    }

    /// The Prometheus text format (version 0.0.4).
    pub fn render(&self) -> String {
        let mut out = String::new();
        out.push_str("# HELP spherefit_http_requests_total HTTP requests by route, method and status.\n# TYPE spherefit_http_requests_total counter\n");
        for ((route, method, status), n) in lock(&self.requests).iter() {
            let _ = writeln!(
                out,
                "spherefit_http_requests_total{{route=\"{}\",method=\"{}\",status=\"{status}\"}} {n}",
                esc(route),
                esc(method)
            );
        }
        out.push_str("# HELP spherefit_http_errors_total Error responses by route, status and problem type.\n# TYPE spherefit_http_errors_total counter\n");
        for ((route, status, problem), n) in lock(&self.errors).iter() {
            let _ = writeln!(
                out,
                "spherefit_http_errors_total{{route=\"{}\",status=\"{status}\",type=\"{}\"}} {n}",
                esc(route),
                esc(problem)
            );
        }
        for (name, help, by_route) in [
            (
                "spherefit_http_request_duration_seconds",
                "Request durations by route.",
                &self.request_duration,
            ),
            (
                "spherefit_fit_duration_seconds",
                "CPU work (fitting, interpolation, evaluation) per request, by route.",
                &self.fit_duration,
            ),
        ] {
            let _ = writeln!(out, "# HELP {name} {help}\n# TYPE {name} histogram");
            for (route, h) in lock(by_route).iter() {
                h.render(&mut out, name, &format!("route=\"{}\"", esc(route)));
            }
        }
        for (name, help, by_route) in [
            (
                "spherefit_points_fitted_total",
                "Input points processed, by route.",
                &self.points,
            ),
            (
                "spherefit_curves_total",
                "Curves fitted, interpolated or evaluated, by route.",
                &self.curves,
            ),
        ] {
            let _ = writeln!(out, "# HELP {name} {help}\n# TYPE {name} counter");
            for (route, n) in lock(by_route).iter() {
                let _ = writeln!(out, "{name}{{route=\"{}\"}} {n}", esc(route));
            }
        }
        let _ = write!(
            out,
            "# HELP spherefit_overload_rejections_total Requests refused with 503 because every fitting slot and the queue were taken.\n# TYPE spherefit_overload_rejections_total counter\nspherefit_overload_rejections_total {}\n\
             # HELP spherefit_timeouts_total Requests that ran out of their time budget (503).\n# TYPE spherefit_timeouts_total counter\nspherefit_timeouts_total {}\n\
             # HELP spherefit_fits_in_progress Requests holding a fitting slot.\n# TYPE spherefit_fits_in_progress gauge\nspherefit_fits_in_progress {}\n\
             # HELP spherefit_fits_waiting Requests queued for a fitting slot.\n# TYPE spherefit_fits_waiting gauge\nspherefit_fits_waiting {}\n",
            self.overload_rejections.load(Ordering::Relaxed),
            self.timeouts.load(Ordering::Relaxed),
            self.fits_in_progress.load(Ordering::Relaxed),
            self.fits_waiting.load(Ordering::Relaxed),
        );
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn renders_counters_and_histograms() {
        let m = Metrics::default();
        m.record_request("/v1/fit", "POST", 200, None, 0.02);
        m.record_request("/v1/fit", "POST", 422, Some("too-few-points"), 0.001);
        m.record_fit("/v1/fit", 0.015, 966, 1);
        let text = m.render();
        assert!(text.contains(
            "spherefit_http_requests_total{route=\"/v1/fit\",method=\"POST\",status=\"200\"} 1"
        ));
        assert!(text.contains(
            "spherefit_http_errors_total{route=\"/v1/fit\",status=\"422\",type=\"too-few-points\"} 1"
        ));
        assert!(text.contains(
            "spherefit_http_request_duration_seconds_bucket{route=\"/v1/fit\",le=\"0.025\"} 2"
        ));
        assert!(text.contains("spherefit_points_fitted_total{route=\"/v1/fit\"} 966"));
    }
}
