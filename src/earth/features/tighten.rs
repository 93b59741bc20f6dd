//! Validity of fitted polygons: rings that meet themselves or their feature's other rings
//! where the input's did not are refitted tighter ([`crate::earth::polygon::validity`]).

use crate::earth::curve::fitting::fit_line_to_tolerance;
use crate::earth::curve::output::CurveOutput;
use crate::earth::error::EarthError;
use crate::earth::features::run::output_spec;
use crate::earth::features::CurveJob;
use crate::earth::job::{Job, Operation};
use crate::earth::lonlat::lonlat_to_unit;
use crate::earth::lonlat::m_to_rad;
use crate::earth::polygon::small_rings;
use crate::earth::polygon::splice::refit_line_around;
use crate::earth::polygon::validity::{splice_around, tighten, Drawn, LAST_RESORT_M, REFIT_ROUNDS};
use crate::sphere::compress::tolerance::MAX_LENGTH_RATIO;
use crate::sphere::fit::options::FitOptions;

use serde_json::{json, Value};

/// Validity: the fitted rings of one feature (exterior rings, holes, the polygons of a
/// MultiPolygon) must not meet themselves or each other where the input's rings did not, on
/// the sphere or as written ([`crate::earth::polygon::validity`]). At a loose tolerance a fitted ring can
/// cut across a narrow inlet, touch its hole (Antarctica's peninsula at 10 km does) or an island
/// nearby (the Curonian Spit and Lithuania's coast at 1 km); each ring of such a pair is
/// refitted tighter, up to [`REFIT_ROUNDS`] times (around the meeting only where it can be),
/// and its report gives the tolerance it was fitted to. Only tolerance fits tighten: a fit to a fixed number of control points, or an
/// interpolation, is what was asked for.
pub(super) fn tighten_crossing_rings(
    jobs: &[CurveJob<'_>],
    outputs: &mut [CurveOutput],
    job: &Job,
) -> Result<(), EarthError> {
    let Operation::FitToTolerance {
        options,
        tolerance_m,
    } = &job.operation
    else {
        return Ok(());
    };
    // Rings kept as small are left alone where they are to be dropped (drop_small_rings): a
    // tighter refit would keep an islet the user asked to drop.
    let to_drop =
        |i: usize| job.drop_small_rings && outputs[i].report.fields.contains_key("small_ring");
    let rings: Vec<usize> = (0..jobs.len())
        .filter(|&i| jobs[i].closed && !to_drop(i))
        .collect();
    // The input is judged as it would be written at the output's precision: a ring that
    // rounding alone makes meet itself is excused (no fit could write it valid).
    let precision = job.output.precision;
    let units: Vec<Vec<[f64; 3]>> = jobs.iter().map(|c| ring_units(c.value)).collect();
    let input = Drawn::new(units.iter().map(Vec::as_slice).collect(), Some(precision));
    // Fitted rings move at most the tolerance from their input (a tightened refit less).
    let pairs = input.near_pairs(&rings, 2.0 * m_to_rad(*tolerance_m));
    tighten(
        &input,
        &pairs,
        *tolerance_m,
        REFIT_ROUNDS,
        outputs,
        |o: &CurveOutput| o.points.as_slice(),
        |i, t, old, at| {
            let _scope = job.cancel.enter();
            let c = &jobs[i];
            if let Some(out) = refit_around(c, options, (*tolerance_m, t), old, at, job)? {
                return Ok(Some(out));
            }
            let mut out =
                fit_line_to_tolerance(c.line(), options, t, c.times.as_ref(), output_spec(job))?;
            job_tolerance_met(&mut out, *tolerance_m);
            // A refit that collapsed (or shrank below a triangle) keeps the earlier fit.
            Ok::<_, EarthError>((!small_rings::collapsed(&out, precision)).then_some(out))
        },
    )?;
    Ok(())
}

/// Ring `c` (fitted as `old`, to the job's tolerance `tolerance_m` or tighter) refitted at `t`
/// around its segments `at` only ([`refit_line_around`]), where it meets another ring or
/// itself, when that can be done and the ring then meets the job's tolerance
/// ([`splice_around`]). The second round at [`LAST_RESORT_M`] refits whole rings.
fn refit_around(
    c: &CurveJob<'_>,
    options: &FitOptions,
    (tolerance_m, t): (f64, f64),
    old: &CurveOutput,
    at: &[usize],
    job: &Job,
) -> Result<Option<CurveOutput>, EarthError> {
    // The first round at the last resort splices too, with wide windows (Greenland's 10m
    // ring at 5 km: one meeting left after four rounds, and a whole refit at 1 cm stored
    // all 15,536 positions); the second refits whole.
    let old_t = old.report.fields.get("tolerance_m").and_then(Value::as_f64);
    let last_resort_before = old_t.is_some_and(|o| o <= LAST_RESORT_M);
    if last_resort_before || c.times.is_some() || old.kept.is_none() {
        return Ok(None);
    }
    let precision = job.output.precision;
    splice_around(
        (&old.points, at),
        (tolerance_m, t, precision),
        |o: &CurveOutput| o.points.as_slice(),
        |at, margin| {
            let out = refit_line_around(
                c.line(),
                options,
                (tolerance_m, t),
                old,
                (at, margin),
                output_spec(job),
            )?;
            Ok(out.map(|mut out| {
                job_tolerance_met(&mut out, tolerance_m);
                out
            }))
        },
        |out| {
            out.report.fields.get("tolerance_met") == Some(&Value::Bool(true))
                && !small_rings::collapsed(out, precision)
        },
    )
}

/// A ring refitted tighter reports `tolerance_m` as what it was fitted to, and
/// `tolerance_met` against the job's tolerance (the promise the user asked for): the last
/// refit aims at a centimetre, which rounding to 7 decimals alone can exceed, and a ring within
/// 2 cm of its input meets a 100 m tolerance.
fn job_tolerance_met(out: &mut CurveOutput, tolerance_m: f64) {
    let f = &mut out.report.fields;
    let m = |k: &str| f.get(k).and_then(Value::as_f64).unwrap_or(f64::INFINITY);
    let worst = m("max_error_m").max(m("two_way_distance_m"));
    let long = m("curve_length_ratio") > MAX_LENGTH_RATIO;
    f.insert("tolerance_met".into(), json!(worst <= tolerance_m && !long));
}

/// A ring's positions as unit vectors (positions that are not two numbers are skipped: they
/// were refused before any fit ran).
pub(super) fn ring_units(ring: &Value) -> Vec<[f64; 3]> {
    ring.as_array()
        .map(|ps| {
            ps.iter()
                .filter_map(|p| Some(lonlat_to_unit(p.get(0)?.as_f64()?, p.get(1)?.as_f64()?)))
                .collect()
        })
        .unwrap_or_default()
}
