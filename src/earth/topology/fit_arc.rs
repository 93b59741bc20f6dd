//! One arc of a coverage fitted to the tolerance with pinned ends, rounded, sampled and
//! measured as returned.

use super::*;

/// Fits one arc to the tolerance with pinned ends (see the module docs), rounds it, samples it
/// and measures the curve as returned.
pub(super) fn fit_arc(
    points_in: &[[f64; 3]],
    closed: bool,
    tol_rad: f64,
    degree_cap: usize,
    parameterization: crate::sphere::Parameterization,
    job: &Job,
) -> Result<FittedArc, EarthError> {
    let mut rows = points_in.to_vec();
    let mut smooth_seam = false;
    if closed {
        // Start the closed curve at its sharpest corner: a C0 seam there costs nothing.
        rows.pop();
        let n = rows.len();
        let mut cyc = Vec::with_capacity(n + 2);
        cyc.push(rows[n - 1]);
        cyc.extend_from_slice(&rows);
        cyc.push(rows[0]);
        let set = PointSet::try_from_rows(&cyc).map_err(|e| sphere_error(e, "", &[]))?;
        let turns = turning_angles(&set);
        let (k, turn) = (0..n)
            .map(|i| (i, turns[i + 1]))
            .max_by(|a, b| a.1.total_cmp(&b.1))
            .expect("a ring has vertices");
        rows.rotate_left(k);
        rows.push(rows[0]);
        smooth_seam = turn < CORNER_ANGLE_RAD;
    }
    let n_in = if closed { rows.len() - 1 } else { rows.len() };
    let points = PointSet::try_from_rows(&rows).map_err(|e| sphere_error(e, "", &[]))?;
    let output = &job.output;
    let bound = rounding_bound_rad(output.precision);
    let dense_margin = AUTO_DEVIATION_FRACTION * tol_rad;
    let mut target = tolerance_target_rad(tol_rad, output.precision);
    let mut topts = ToleranceOptions {
        parameterization,
        max_control_points: Some(points.len()),
        pin_ends: true,
        measure_result: false,
        ..ToleranceOptions::default()
    };
    topts.degrees.retain(|&p| p <= degree_cap);
    let measure = |spline: &SphericalBSpline, params: &[f64]| -> Result<(f64, f64), EarthError> {
        let errs = pointwise_errors(spline, &points, params);
        let max = errs.iter().fold(0.0f64, |a, &b| a.max(b));
        let tw = two_way_distance(
            spline,
            &points,
            params,
            &TwoWayOptions::default()
                .with_precision_rad(0.01 * tol_rad)
                .with_max_evaluations(4_000_000 + 400 * points.len()),
        )
        .map_err(|e| sphere_error(e, "", &[]))?;
        Ok((max, tw.upper_rad))
    };
    let mut attempt = 0;
    let (spline, control_ll, rule, max_rad, tw_rad, seam) = loop {
        let r = fit_to_tolerance(&points, None, target, &topts)
            .map_err(|e| sphere_error(e, "", &[]))?;
        let (rounded, ll) =
            round_spline(&r.spline, output.precision).map_err(|e| sphere_error(e, "", &[]))?;
        let (max, tw) = measure(&rounded, &r.parameters)?;
        let mut best = (
            rounded,
            ll,
            r.knot_rule,
            max,
            tw,
            closed.then_some("corner"),
        );
        if closed && smooth_seam && r.spline.degree() >= 2 {
            // A C1 seam where the ring is smooth, kept when the tolerance still holds.
            if let Ok(c1) = close_seam(&r.spline, true) {
                if let Ok((rc, llc)) = round_spline(&c1, output.precision) {
                    let (m2, t2) = measure(&rc, &r.parameters)?;
                    if m2.max(t2) <= tol_rad {
                        best = (rc, llc, r.knot_rule, m2, t2, Some("smooth"));
                    }
                }
            }
        }
        let worst = best.3.max(best.4);
        if worst > tol_rad && r.tolerance_met && attempt == 0 {
            let lower = target - 2.0 * (worst - tol_rad) - bound;
            if lower > 0.25 * tol_rad {
                target = lower;
                attempt += 1;
                continue;
            }
        }
        break best;
    };
    // A closed arc is a whole ring: at least 4 positions (RFC 7946 §3.1.6).
    let sampling = match output.sampling {
        crate::earth::Sampling::Samples(n) if closed && n < 4 => crate::earth::Sampling::Samples(4),
        crate::earth::Sampling::SpacingM(spacing_m) if closed => {
            crate::earth::Sampling::SpacingAndSamples {
                spacing_m,
                samples: 4,
            }
        }
        s => s,
    };
    let dense = sample(
        &spline,
        sampling,
        dense_margin,
        sampling_start(spline.control_points().len()),
        job.limits.max_samples,
    )
    .map_err(|e| EarthError::new("", e.problem))?;
    let mut pts = dense.points.clone();
    let last = pts.len() - 1;
    // The ends are the (pinned, rounded) end control points exactly.
    let cps = spline.control_points();
    let (c0, c1) = (cps.get(0), cps.get(cps.len() - 1));
    pts[0] = [c0[0], c0[1], c0[2]];
    pts[last] = [c1[0], c1[1], c1[2]];
    let precision = output.precision;
    let mut dense_ll: Vec<[f64; 2]> = pts
        .iter()
        .map(|p| {
            let (lon, lat) = unit_to_lonlat(p);
            [round_to(lon, precision), round_to(lat, precision)]
        })
        .collect();
    dense_ll[0] = control_ll[0];
    dense_ll[last] = control_ll[control_ll.len() - 1];
    if closed {
        dense_ll[last] = dense_ll[0];
        pts[last] = pts[0];
    }
    // Neighbours that round to one position are written once: readers that join arcs (GDAL,
    // topojson-client) would otherwise keep a zero-length edge the GeoJSON output does not
    // have. The ends stay (a closed arc keeps both copies of its first position).
    let mut keep = vec![true; dense_ll.len()];
    let mut prev = 0;
    for i in 1..dense_ll.len() {
        if dense_ll[i] == dense_ll[prev] && i != last {
            keep[i] = false;
        } else {
            if dense_ll[i] == dense_ll[prev] && prev != 0 {
                keep[prev] = false;
            }
            prev = i;
        }
    }
    if keep.iter().any(|k| !k) {
        let mut k = keep.iter();
        dense_ll.retain(|_| *k.next().expect("one flag a position"));
        let mut k = keep.iter();
        pts.retain(|_| *k.next().expect("one flag a position"));
    }
    let stored = stored_numbers(&spline, rule);
    let met = max_rad.max(tw_rad) <= tol_rad;
    Ok(FittedArc {
        stored_numbers: stored,
        knot_rule: rule,
        control_ll,
        dense: pts,
        dense_ll,
        max_error_rad: max_rad,
        two_way_rad: tw_rad,
        tolerance_met: met,
        input_points: n_in,
        seam,
        sampling_deviation_rad: dense.max_deviation_rad,
        tolerance_rad: tol_rad,
        spline,
    })
}

/// Whether a fitted arc meets `tol_rad` (the job's tolerance, for an arc refitted tighter).
pub(super) fn tolerance_met_by(arc: &FittedArc, tol_rad: f64) -> bool {
    arc.max_error_rad.max(arc.two_way_rad) <= tol_rad
}
