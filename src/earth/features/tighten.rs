//! Validity of fitted polygons: rings that meet themselves or their feature's other rings
//! where the input's did not are refitted tighter ([`crate::earth::validity`]).

use super::*;
use crate::earth::lonlat::m_to_rad;
use crate::earth::topology::TIGHTEN_ROUNDS;
use crate::earth::validity::{tighten, Drawn};

/// Validity: the fitted rings of one feature (exterior rings, holes, the polygons of a
/// MultiPolygon) must not meet themselves or each other where the input's rings did not, on
/// the sphere or as written ([`crate::earth::validity`]). At a loose tolerance a fitted ring can
/// cut across a narrow inlet, touch its hole (Antarctica's peninsula at 10 km does) or an island
/// nearby (the Curonian Spit and Lithuania's coast at 1 km); each ring of such a pair is
/// refitted tighter, up to [`TIGHTEN_ROUNDS`] times, and its report gives the tolerance it was
/// fitted to. Only tolerance fits tighten: a fit to a fixed number of control points, or an
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
        TIGHTEN_ROUNDS,
        outputs,
        |o: &CurveOutput| o.points.as_slice(),
        |i, t| {
            let _scope = job.cancel.enter();
            let c = &jobs[i];
            let out =
                fit_line_to_tolerance(c.line(), options, t, c.times.as_ref(), output_spec(job))?;
            // A refit that collapsed (or shrank below a triangle) keeps the earlier fit.
            Ok::<_, EarthError>((!small_rings::collapsed(&out, precision)).then_some(out))
        },
    )?;
    Ok(())
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
