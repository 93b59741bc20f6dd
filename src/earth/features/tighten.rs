//! Validity of fitted polygons: rings that cross themselves or their polygon's other rings
//! where the input's did not are refitted at half their tolerance.

use super::*;

/// How many times a ring whose fit crosses itself or another ring of its polygon is refitted at
/// half its tolerance (as the shared fit does with its arcs).
pub(super) const TIGHTEN_ROUNDS: usize = 3;

/// Validity: the fitted rings of one polygon (exterior and holes) must not cross themselves or
/// each other where the input's rings did not. At a loose tolerance a fitted ring can cut across
/// a narrow inlet or touch its hole (Antarctica's peninsula at 10 km does); each ring of such a
/// pair is refitted at half its tolerance, up to [`TIGHTEN_ROUNDS`] times, and its report gives
/// the tolerance it was fitted to. Only tolerance fits tighten: a fit to a fixed number of
/// control points, or an interpolation, is what was asked for.
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
    // Rings by polygon: the path without its last index.
    let mut polygons: BTreeMap<&[usize], Vec<usize>> = BTreeMap::new();
    for (i, c) in jobs.iter().enumerate() {
        if c.closed && !c.path.is_empty() {
            polygons
                .entry(&c.path[..c.path.len() - 1])
                .or_default()
                .push(i);
        }
    }
    let pairs: Vec<(usize, usize)> = polygons
        .values()
        .flat_map(|rings| {
            rings
                .iter()
                .enumerate()
                .flat_map(move |(k, &a)| rings[k..].iter().map(move |&b| (a, b)))
        })
        .collect();
    let cross = |p: &[[f64; 3]], q: &[[f64; 3]], same| polylines_cross(p, q, same);
    let input: Vec<Vec<[f64; 3]>> = jobs.iter().map(|c| ring_units(c.value)).collect();
    let input_crossing: Vec<bool> = pairs
        .par_iter()
        .map(|&(a, b)| cross(&input[a], &input[b], a == b))
        .collect();
    let mut tolerance = vec![*tolerance_m; jobs.len()];
    for _ in 0..TIGHTEN_ROUNDS {
        let crossing: Vec<(usize, usize)> = pairs
            .par_iter()
            .zip(&input_crossing)
            .filter(|&(&(a, b), &was)| {
                !was && cross(&outputs[a].points, &outputs[b].points, a == b)
            })
            .map(|(&p, _)| p)
            .collect();
        if crossing.is_empty() {
            break;
        }
        let mut redo: Vec<usize> = crossing.iter().flat_map(|&(a, b)| [a, b]).collect();
        redo.sort_unstable();
        redo.dedup();
        let refits: Vec<(usize, CurveOutput)> = redo
            .par_iter()
            .map(|&i| {
                let _scope = job.cancel.enter();
                let c = &jobs[i];
                let t = 0.5 * tolerance[i];
                fit_line_to_tolerance(c.line(), options, t, c.times.as_ref(), output_spec(job))
                    .map(|out| (i, out))
            })
            .collect::<Result<_, _>>()?;
        for (i, out) in refits {
            tolerance[i] *= 0.5;
            // A refit that collapsed (or shrank below a triangle) keeps the earlier fit.
            if !small_rings::collapsed(&out, job.output.precision) {
                outputs[i] = out;
            }
        }
    }
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
