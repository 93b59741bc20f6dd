//! Dense output of a curve on S^2: a polyline of great-circle segments close to the curve.
//!
//! * [`Sampling::Samples`]`(n)`: n points at evenly spaced parameters, ends included.
//! * [`Sampling::SpacingM`]`(s)`: points about `s` metres apart along the curve (evenly spaced in
//!   arc length, measured on a fine pre-sampling), ends included.
//! * [`Sampling::SpacingAndSamples`]: both at once: at most `spacing_m` apart and at least
//!   `samples` points (evenly spaced in arc length).
//! * [`Sampling::Auto`] (default): [`crate::sphere::certify::dense::sample_within`]: chords halved only
//!   where a proven bound of their distance to the curve exceeds a tolerance, so bends get many
//!   points and straight stretches few. The tolerance is [`AUTO_DEVIATION_FRACTION`] of the
//!   fit's max error, and at least [`AUTO_DEVIATION_FLOOR_M`]. The reported deviation is that
//!   proven bound: the output polyline and the curve are nowhere farther apart (both ways).
//!
//! The other modes report the largest midpoint deviation they measured (`max_deviation_rad`),
//! a measurement rather than a bound.

use crate::earth::error::{EarthError, Problem};
use crate::earth::lonlat::m_to_rad;
use crate::sphere::curve::even_parameters;
use crate::sphere::curve::SphericalCurve;

/// Automatic sampling keeps the polyline within this fraction of the fit's max error of the
/// curve: 5 % is "far below" the error while costing about 1/sqrt(0.05) = 4.5x fewer points
/// than 0.25 %.
pub const AUTO_DEVIATION_FRACTION: f64 = 0.05;

/// Smallest tolerance of automatic sampling, in metres. The proof of a chord's bound costs
/// curve evaluations in proportion to the chord's length over the tolerance (the speed bound
/// of a SLERP triangle is first-order tight), so near-exact fits of synthetic lines at the old
/// 5 cm floor spent millions of evaluations per curve; half a metre is far below every real
/// line's fit error and below what a map shows. Tolerance fits aim at a share of their
/// tolerance instead (at least this).
pub const AUTO_DEVIATION_FLOOR_M: f64 = 0.5;

/// How densely an output line is sampled.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Sampling {
    /// Adaptive: dense enough that the deviation is far below the fit error.
    #[default]
    Auto,
    /// This many points per line, evenly spaced in parameter.
    Samples(usize),
    /// About this many metres between output points.
    SpacingM(f64),
    /// A curve in time sampled every this many seconds from its start (and at its end).
    SpacingS(f64),
    /// At most `spacing_m` metres apart and at least `samples` points.
    SpacingAndSamples {
        /// Largest distance between output points, metres.
        spacing_m: f64,
        /// Fewest output points.
        samples: usize,
    },
}

impl Sampling {
    /// The sampling asked for by a number of points and a spacing in metres, as every front
    /// end reads them: both together are at most that far apart and at least that many points;
    /// neither is automatic.
    pub fn from_samples_and_spacing(samples: Option<usize>, spacing_m: Option<f64>) -> Sampling {
        match (samples, spacing_m) {
            (Some(n), Some(s)) => Sampling::SpacingAndSamples {
                spacing_m: s,
                samples: n,
            },
            (Some(n), None) => Sampling::Samples(n),
            (None, Some(s)) => Sampling::SpacingM(s),
            (None, None) => Sampling::Auto,
        }
    }
}

/// A curve sampled densely.
#[derive(Clone, Debug)]
pub struct DenseCurve {
    /// Curve parameters of the output points.
    pub params: Vec<f64>,
    /// Output points (unit vectors).
    pub points: Vec<[f64; 3]>,
    /// Distance, in radians, between the curve and the polyline: a proven bound (both ways) for
    /// [`Sampling::Auto`], the largest deviation at segment midpoints for the other modes.
    pub max_deviation_rad: f64,
}

fn to3(curve: &dyn SphericalCurve, ts: &[f64]) -> Vec<[f64; 3]> {
    let ps = curve.evaluate_many(ts);
    ps.iter().map(|p| [p[0], p[1], p[2]]).collect()
}

/// Distance in radians from `m` to the great-circle segment `a`-`b` (its great circle, or the
/// end point when the segment has no length).
fn deviation(a: &[f64; 3], b: &[f64; 3], m: &[f64; 3]) -> f64 {
    let n = [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ];
    let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
    if len < 1e-15 {
        return crate::sphere::geometry::point::angle_between(a, m);
    }
    let s = (n[0] * m[0] + n[1] * m[1] + n[2] * m[2]) / len;
    s.clamp(-1.0, 1.0).asin().abs()
}

fn midpoint_deviations(curve: &dyn SphericalCurve, ts: &[f64], pts: &[[f64; 3]]) -> Vec<f64> {
    let mids: Vec<f64> = ts.windows(2).map(|w| 0.5 * (w[0] + w[1])).collect();
    let mp = to3(curve, &mids);
    (0..mids.len())
        .map(|i| deviation(&pts[i], &pts[i + 1], &mp[i]))
        .collect()
}

/// Samples `curve` (on S^2) densely.
///
/// `auto_tolerance_rad` is the deviation automatic sampling aims for; `start` its initial number
/// of evenly spaced points (e.g. a few per control point); `max_samples` the most points allowed.
///
/// # Errors
/// [`Problem::TooManySamples`] when `spacing_m` needs more than `max_samples` points.
pub fn sample(
    curve: &dyn SphericalCurve,
    sampling: Sampling,
    auto_tolerance_rad: f64,
    start: usize,
    max_samples: usize,
) -> Result<DenseCurve, EarthError> {
    let max_samples = max_samples.max(2);
    let domain = curve.domain();
    match sampling {
        Sampling::Samples(n) => {
            if n > max_samples {
                return Err(EarthError::new(
                    "",
                    Problem::TooManySamples {
                        needed: n,
                        max: max_samples,
                    },
                ));
            }
            let ts = even_parameters(domain, n.max(2));
            Ok(finish(curve, ts))
        }
        Sampling::SpacingM(spacing_m) => {
            let ts = by_arc_length(curve, m_to_rad(spacing_m), 2, start, max_samples)?;
            Ok(finish(curve, ts))
        }
        Sampling::SpacingAndSamples { spacing_m, samples } => {
            let ts = by_arc_length(curve, m_to_rad(spacing_m), samples, start, max_samples)?;
            Ok(finish(curve, ts))
        }
        // Only a curve in time knows its seconds (`sample_in_time`).
        Sampling::SpacingS(_) => Err(EarthError::new(
            "",
            Problem::InvalidOption {
                option: "spacing_s",
                message: "this curve is not in time: fit with parameterization time".into(),
            },
        )),
        // Certified halving needs no evenly spaced start: the ends and the curve's breaks
        // (knots, joints) are where it begins, so a polyline comes out as its vertices.
        Sampling::Auto => Ok(adaptive(curve, auto_tolerance_rad, 2, max_samples)),
    }
}

/// Curve parameters every `spacing_s` seconds of a curve spanning `duration_s` seconds on
/// `[0, 1]`, its end included; the count is checked against `max_samples` before the list is
/// made.
///
/// # Errors
/// [`Problem::InvalidOption`] naming `spacing_s`.
pub fn time_parameters(
    duration_s: f64,
    spacing_s: f64,
    max_samples: usize,
) -> Result<Vec<f64>, EarthError> {
    let steps = (duration_s / spacing_s).floor();
    let needed_f = steps + 2.0;
    if needed_f.is_nan() || needed_f > max_samples.max(2) as f64 {
        return Err(EarthError::new(
            "",
            Problem::InvalidOption {
                option: "spacing_s",
                message: format!(
                    "{} output points needed for {duration_s} s, more than the limit of {max_samples} per line: use a larger spacing_s",
                    if needed_f.is_finite() { format!("{needed_f}") } else { "too many".into() }
                ),
            },
        ));
    }
    let steps = steps as usize;
    let mut ts: Vec<f64> = (0..=steps)
        .map(|k| k as f64 * spacing_s / duration_s)
        .filter(|&u| u < 1.0)
        .collect();
    ts.push(1.0);
    Ok(ts)
}

/// A curve sampled at the given parameters.
pub fn sample_at(curve: &dyn SphericalCurve, ts: Vec<f64>) -> DenseCurve {
    finish(curve, ts)
}

fn finish(curve: &dyn SphericalCurve, ts: Vec<f64>) -> DenseCurve {
    let points = to3(curve, &ts);
    let max_deviation_rad = midpoint_deviations(curve, &ts, &points)
        .into_iter()
        .fold(0.0, f64::max);
    DenseCurve {
        params: ts,
        points,
        max_deviation_rad,
    }
}

/// Parameters at most `spacing_rad` apart in arc length (evenly spaced, at least `min_count`),
/// from a fine table of the curve.
fn by_arc_length(
    curve: &dyn SphericalCurve,
    spacing_rad: f64,
    min_count: usize,
    start: usize,
    max_samples: usize,
) -> Result<Vec<f64>, EarthError> {
    let table_n = (16 * start).clamp(1024, 65_536);
    let ts = even_parameters(curve.domain(), table_n);
    let pts = to3(curve, &ts);
    let mut cum = Vec::with_capacity(table_n);
    cum.push(0.0);
    for w in pts.windows(2) {
        let prev = *cum.last().expect("non-empty");
        cum.push(prev + crate::sphere::geometry::point::angle_between(&w[0], &w[1]));
    }
    let total = *cum.last().expect("non-empty");
    let needed_f = ((total / spacing_rad).ceil() + 1.0).max(min_count as f64);
    if needed_f > max_samples as f64 {
        return Err(EarthError::new(
            "",
            Problem::TooManySamples {
                needed: needed_f.min(usize::MAX as f64) as usize,
                max: max_samples,
            },
        ));
    }
    let n = (needed_f as usize).max(2);
    let mut out = Vec::with_capacity(n);
    let mut j = 0;
    for k in 0..n {
        let target = total * k as f64 / (n - 1) as f64;
        while j + 2 < cum.len() && cum[j + 1] < target {
            j += 1;
        }
        let (c0, c1) = (cum[j], cum[j + 1]);
        let f = if c1 > c0 {
            ((target - c0) / (c1 - c0)).clamp(0.0, 1.0)
        } else {
            0.0
        };
        out.push(ts[j] + f * (ts[j + 1] - ts[j]));
    }
    out[0] = ts[0];
    out[n - 1] = ts[table_n - 1];
    Ok(out)
}

/// Curve evaluations automatic sampling may spend per knot span (at least
/// [`AUTO_MIN_EVALUATIONS`] in all, at most 8 per allowed output point): proving each chord's
/// bound costs evaluations, and a smooth curve that bends tightly between its knots would
/// otherwise spend seconds proving centimetres (a 2,000-point synthetic wave: 2.8 s for 0.5 m).
/// Past the budget the output keeps the bound proven so far, and reports it.
pub const AUTO_EVALUATIONS_PER_SPAN: usize = 512;

/// See [`AUTO_EVALUATIONS_PER_SPAN`].
pub const AUTO_MIN_EVALUATIONS: usize = 262_144;

/// Certified adaptive sampling ([`crate::sphere::certify::dense::sample_within_budget`]).
fn adaptive(curve: &dyn SphericalCurve, tol: f64, start: usize, max_samples: usize) -> DenseCurve {
    let spans = curve.breaks().len() + 1;
    let budget = AUTO_EVALUATIONS_PER_SPAN
        .saturating_mul(spans)
        .max(AUTO_MIN_EVALUATIONS)
        .min(8usize.saturating_mul(max_samples.max(2)));
    let d =
        crate::sphere::certify::dense::sample_within_budget(curve, tol, start, max_samples, budget);
    DenseCurve {
        points: d.points.iter().map(|p| [p[0], p[1], p[2]]).collect(),
        params: d.params,
        max_deviation_rad: d.deviation_rad,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::earth::lonlat::{lonlat_to_unit, rad_to_m};
    use crate::sphere::{PointSet, SphericalBSpline};

    /// A quarter of a small circle at 60 N, as a degree-2 spline through 3 control points.
    fn arc() -> SphericalBSpline {
        let rows: Vec<Vec<f64>> = [(0.0, 60.0), (45.0, 62.0), (90.0, 60.0)]
            .iter()
            .map(|&(a, b)| lonlat_to_unit(a, b).to_vec())
            .collect();
        SphericalBSpline::try_new(
            2,
            vec![0.0, 0.0, 0.0, 1.0, 1.0, 1.0],
            PointSet::try_from_rows(&rows).unwrap(),
        )
        .unwrap()
    }

    #[test]
    fn samples_are_exact_in_number() {
        let d = sample(&arc(), Sampling::Samples(17), 0.0, 8, 100).unwrap();
        assert_eq!(d.points.len(), 17);
        assert_eq!(d.params[0], 0.0);
        assert_eq!(d.params[16], 1.0);
        let e = sample(&arc(), Sampling::Samples(170), 0.0, 8, 100).unwrap_err();
        assert!(matches!(e.problem, Problem::TooManySamples { .. }));
    }

    #[test]
    fn spacing_gives_even_steps_in_metres() {
        let d = sample(&arc(), Sampling::SpacingM(10_000.0), 0.0, 8, 100_000).unwrap();
        let steps: Vec<f64> = d
            .points
            .windows(2)
            .map(|w| rad_to_m(crate::sphere::geometry::point::angle_between(&w[0], &w[1])))
            .collect();
        let (lo, hi) = steps
            .iter()
            .fold((f64::MAX, 0.0f64), |(l, h), &s| (l.min(s), h.max(s)));
        assert!(hi <= 10_000.0 && lo > 9_900.0, "{lo} {hi}");
    }

    #[test]
    fn automatic_sampling_meets_its_tolerance() {
        // 10 m on a 5,000 km arc: proving 1 m there costs more evaluations than the budget
        // (`AUTO_MIN_EVALUATIONS`); the bound reported is then honest but above the aim.
        let tol = m_to_rad(10.0);
        let d = sample(&arc(), Sampling::Auto, tol, 4, 100_000).unwrap();
        assert!(d.max_deviation_rad <= tol, "{}", d.max_deviation_rad);
        // An independent check at quarter points of every segment.
        let c = arc();
        let qs: Vec<f64> = d
            .params
            .windows(2)
            .map(|w| 0.75 * w[0] + 0.25 * w[1])
            .collect();
        let q = c.evaluate_many(&qs);
        for (i, p) in q.iter().enumerate() {
            let p = [p[0], p[1], p[2]];
            assert!(deviation(&d.points[i], &d.points[i + 1], &p) <= tol);
        }
        // And it did not use more points than needed by a wide margin.
        let coarse = sample(&arc(), Sampling::Auto, 4.0 * tol, 4, 100_000).unwrap();
        assert!(coarse.points.len() < d.points.len());
    }

    #[test]
    fn automatic_sampling_stops_at_the_limit() {
        let d = sample(&arc(), Sampling::Auto, 1e-15, 4, 50).unwrap();
        assert!(d.points.len() <= 50);
        assert!(d.max_deviation_rad > 1e-15);
        // The bound it reports still holds: along each chord, 81 curve points against it.
        let c = arc();
        for (j, span) in d.params.windows(2).enumerate() {
            let ts: Vec<f64> = (0..=80)
                .map(|k| span[0] + (span[1] - span[0]) * f64::from(k) / 80.0)
                .collect();
            let q = c.evaluate_many(&ts);
            for k in 0..q.len() {
                let (a, b) = (&d.points[j], &d.points[j + 1]);
                let dev = crate::sphere::geometry::arc::distance_to_arc(q.get(k), a, b);
                assert!(
                    dev <= d.max_deviation_rad,
                    "chord {j}: {dev} > {}",
                    d.max_deviation_rad
                );
            }
        }
    }
}
