//! Wall-clock time of each step of a coverage fit, in order, for `--stats` (`phases`): where
//! a run spends its time, and which steps run on one thread.

use serde_json::{json, Value};
use std::time::Instant;

/// The steps of a run so far and how long each took (seconds of wall time).
#[derive(Clone, Debug)]
pub struct Phases {
    /// `(step, seconds)` in the order the steps ran.
    pub steps: Vec<(&'static str, f64)>,
    since: Instant,
}

impl Default for Phases {
    fn default() -> Self {
        Phases::new()
    }
}

impl Phases {
    /// No steps yet; the first one starts now.
    pub fn new() -> Phases {
        Phases {
            steps: Vec::new(),
            since: Instant::now(),
        }
    }

    /// Ends the step `name` (started when the last one ended) and starts the next.
    pub fn lap(&mut self, name: &'static str) {
        let now = Instant::now();
        self.steps
            .push((name, now.duration_since(self.since).as_secs_f64()));
        self.since = now;
    }

    /// Ends a step that ran the steps of `other` (started when the last one here ended):
    /// `other`'s steps appended, and whatever of the step they do not account for (work
    /// after `other`'s last step, such as freeing its input) as `rest`.
    pub fn lap_with(&mut self, other: &Phases, rest: &'static str) {
        let now = Instant::now();
        let whole = now.duration_since(self.since).as_secs_f64();
        let inner: f64 = other.steps.iter().map(|s| s.1).sum();
        self.steps.extend_from_slice(&other.steps);
        self.steps.push((rest, (whole - inner).max(0.0)));
        self.since = now;
    }

    /// The seconds of the steps so far.
    pub fn total(&self) -> f64 {
        self.steps.iter().map(|s| s.1).sum()
    }

    /// `[[step, seconds], ...]`, seconds rounded to the millisecond.
    pub fn to_json(&self) -> Value {
        Value::Array(
            self.steps
                .iter()
                .map(|(name, s)| json!([name, (s * 1000.0).round() / 1000.0]))
                .collect(),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn steps_add_up_to_the_time_taken_and_nest() {
        let started = Instant::now();
        let mut outer = Phases::new();
        std::thread::sleep(std::time::Duration::from_millis(5));
        outer.lap("a");
        let mut inner = Phases::new();
        std::thread::sleep(std::time::Duration::from_millis(5));
        inner.lap("b");
        std::thread::sleep(std::time::Duration::from_millis(5));
        outer.lap_with(&inner, "b, rest");
        let names: Vec<&str> = outer.steps.iter().map(|s| s.0).collect();
        assert_eq!(names, ["a", "b", "b, rest"]);
        assert!(
            outer.steps.iter().all(|s| s.1 >= 0.004),
            "{:?}",
            outer.steps
        );
        assert!(outer.total() <= started.elapsed().as_secs_f64());
        assert_eq!(outer.to_json()[1][0], "b");
    }
}
