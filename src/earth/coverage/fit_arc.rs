//! One arc of a coverage fitted to the tolerance with pinned ends, rounded, sampled and
//! measured as returned.

use crate::earth::coverage::FittedArc;
use crate::earth::curve::fitting::round_spline_with;
use crate::earth::curve::output::sampling_start;
use crate::earth::curve::positions::sphere_error;
use crate::earth::curve::tolerance_rule::ToleranceRule;
use crate::earth::error::EarthError;
use crate::earth::job::Job;
use crate::earth::lonlat::unit_to_lonlat;
use crate::earth::polygon::small_rings;
use crate::earth::polygon::splice::{splice_windows, spliced_two_way, Splice, Spliced, WindowFit};
use crate::earth::sampling::{sample, AUTO_DEVIATION_FRACTION};
use crate::sphere::certify::two_way::{polyline_length, two_way_distance, TwoWayOptions};
use crate::sphere::compress::tolerance::POLYLINE_FIRST_SHARE;
use crate::sphere::compress::tolerance::{
    fit_to_tolerance, stored_numbers, KnotRule, ToleranceOptions,
};
use crate::sphere::curve::bspline::SphericalBSpline;
use crate::sphere::fit::adaptive_knots::{turning_angles, CORNER_ANGLE_RAD};
use crate::sphere::fit::metrics::pointwise_errors;
use crate::sphere::fit::seam::close_seam;
use crate::sphere::geometry::point::log_map;
use crate::sphere::geometry::point::PointSet;

/// Fits one arc to the tolerance with pinned ends (see the module docs), rounds it, samples it
/// and measures the curve as returned.
pub(super) fn fit_arc(
    points_in: &[[f64; 3]],
    closed: bool,
    tolerance: ToleranceRule,
    degree_cap: usize,
    parameterization: crate::sphere::Parameterization,
    job: &Job,
) -> Result<FittedArc, EarthError> {
    let (rows, smooth_seam) = arc_rows(points_in, closed)?;
    fit_rows(
        rows,
        closed,
        smooth_seam,
        tolerance,
        degree_cap,
        parameterization,
        job,
    )
}

/// Arc `old` (fitted to `points_in`) refitted to `tolerance` only around its segments `at`
/// (ascending indices of `old.dense`: from point `i` to `i + 1`), where it meets another arc
/// or itself: each run of meeting segments, with `margin` old vertices on either side, is
/// refitted as a polyline pinned at the old vertices that bound it, through the positions
/// between them, and spliced in; the rest of the arc is kept as it was
/// ([`splice_windows`], as rings fitted per feature are).
///
/// Refitting a whole arc for one meeting stored a long coast's every stretch at the tighter
/// tolerance: on world-atlas countries-10m at 1 km the coverage stored 283,794 numbers with
/// whole refits and 234,800 with none (docs/speed.md, "seventh session").
///
/// `None` when the arc cannot be refitted so: it is not a polyline on uniform knots written
/// as its vertices, a window holds no position, or the refit is not such a polyline.
pub(super) fn refit_around(
    points_in: &[[f64; 3]],
    closed: bool,
    old: &FittedArc,
    (at, margin): (&[usize], usize),
    tolerance: ToleranceRule,
    parameterization: crate::sphere::Parameterization,
    job: &Job,
) -> Result<Option<FittedArc>, EarthError> {
    let m = old.control_ll.len();
    let written_as_vertices = old.spline.degree() == 1
        && old.spline.has_clamped_uniform_knots()
        && old.control_ll == old.dense_ll;
    if !written_as_vertices {
        return Ok(None);
    }
    let (rows, _) = arc_rows(points_in, closed)?;
    let ctrl = old.spline.control_points();
    let vertices: Vec<[f64; 3]> = (0..m)
        .map(|k| {
            let c = ctrl.get(k);
            [c[0], c[1], c[2]]
        })
        .collect();
    let spliced = splice_windows(&vertices, &old.params, &rows, (at, margin), |sub_rows| {
        let sub = fit_rows(sub_rows, false, false, tolerance, 1, parameterization, job)?;
        let ms = sub.control_ll.len();
        if sub.spline.degree() != 1 || !sub.spline.has_clamped_uniform_knots() || ms < 2 {
            return Ok(None);
        }
        let sub_ctrl = sub.spline.control_points();
        let interior = (1..ms - 1)
            .map(|k| {
                let c = sub_ctrl.get(k);
                ([c[0], c[1], c[2]], sub.control_ll[k])
            })
            .collect();
        Ok(Some(WindowFit {
            interior,
            params: sub.params,
        }))
    })?;
    let Some(Splice {
        vertices: spliced,
        params,
        place,
        changed,
    }) = spliced
    else {
        return Ok(None);
    };
    let (out, out_ll): (Vec<[f64; 3]>, Vec<[f64; 2]>) = spliced
        .into_iter()
        .map(|v| match v {
            Spliced::Old(k) => (vertices[k], old.control_ll[k]),
            Spliced::New(new) => new,
        })
        .unzip();
    let spline = polyline_spline(&out)?;
    let line = ArcLine::new(&rows, closed, tolerance, job)?;
    // The old bound for the stretches kept, the changed ones measured alone, as a ring fitted
    // per feature is (`refit_line_around`): measuring the whole arc again was a third of the
    // coverage's refits (docs/speed.md, "tenth session").
    let measured = match spliced_two_way(
        &out,
        &line.points,
        (&place, &changed),
        old.two_way_rad,
        tolerance.tol_rad,
    )? {
        Some(tw) => line.measured_with(&spline, &params, tw.upper_rad, tw.curve_length_rad),
        None => line.measure(&spline, &params)?,
    };
    line.finish(ArcCurve {
        spline,
        control_ll: out_ll,
        rule: old.knot_rule,
        measured,
        seam: old.seam,
        params,
    })
    .map(Some)
}

/// A closed arc (a whole ring, `points_in` closed by a repeat of its first position) whose fit
/// bounded no area, kept as a polyline through the triangle of three of its own positions that
/// spans it, with more of them where an input position would be farther than the tolerance
/// (less the grid's rounding) from it ([`small_rings::kept_indices`], as a ring fitted per
/// feature is kept), rounded, measured and written as any arc is.
///
/// Kept so, the ring is an arc the validity check sees: kept only when its feature was rebuilt,
/// a triangle went unchecked and could cross its feature's other rings (world-atlas
/// countries-10m at 5 km: Bermuda's islet across its main island, and six more features
/// GEOS found invalid whose input is valid). Refitted tighter, it keeps more of its positions.
///
/// `None` when the ring has fewer than three distinct positions, when they round to fewer on
/// the grid, or when the kept polyline is not within the tolerance as written: the feature is
/// then rebuilt with the ring kept apart, as before.
pub(super) fn keep_arc(
    points_in: &[[f64; 3]],
    tolerance: ToleranceRule,
    job: &Job,
) -> Result<Option<FittedArc>, EarthError> {
    let n = points_in.len().saturating_sub(1);
    if n < 3 || points_in[0] != points_in[n] {
        return Ok(None);
    }
    let target = (tolerance.tol_rad - tolerance.rounding_bound_rad()).max(0.5 * tolerance.tol_rad);
    let Some(idx) = small_rings::kept_indices(points_in, Some(target)) else {
        return Ok(None);
    };
    // Started at the first kept position, so that the positions' parameters rise along it.
    let start = idx[0];
    let mut rows: Vec<[f64; 3]> = (0..n).map(|k| points_in[(start + k) % n]).collect();
    rows.push(rows[0]);
    let kept: Vec<usize> = idx.iter().map(|&i| (i + n - start) % n).collect();
    let kept: Vec<usize> = kept[..kept.len() - 1]
        .iter()
        .copied()
        .chain(std::iter::once(n))
        .collect();
    let line = ArcLine::new(&rows, true, tolerance, job)?;
    let control_ll: Vec<[f64; 2]> = kept
        .iter()
        .map(|&i| {
            let (lon, lat) = unit_to_lonlat(&rows[i]);
            [line.round(lon), line.round(lat)]
        })
        .collect();
    if small_rings::collapsed_lonlat(&control_ll) {
        return Ok(None);
    }
    let vertices: Vec<[f64; 3]> = control_ll
        .iter()
        .map(|p| crate::earth::lonlat::lonlat_to_unit(p[0], p[1]))
        .collect();
    let m = vertices.len();
    let spline = polyline_spline(&vertices)?;
    // Each position's parameter: where it projects onto its span's edge (the nearest place on
    // the great circle, clamped to the edge and never back along it), so that its error is its
    // distance from the edge, which `kept_indices` bounds. (Its share of the input's length
    // along the span put a Norwegian islet of the 50m countries at 20 km over the tolerance.)
    let dot = |p: &[f64], q: &[f64]| (0..3).map(|k| p[k] * q[k]).sum::<f64>();
    let mut params = vec![0.0; n + 1];
    for (s, w) in kept.windows(2).enumerate() {
        let a = &vertices[s];
        // The tangent at `a` towards the edge's other end, as long as the edge: a position's
        // angle from `a` along the edge over that length. Kept corners are never antipodal.
        let towards = log_map(a, &vertices[s + 1]).ok();
        let span = towards.as_deref().map_or(0.0, |t| dot(t, t).sqrt());
        let mut frac: f64 = 0.0;
        for (k, q) in rows[w[0]..=w[1]].iter().enumerate() {
            let along = match &towards {
                Some(t) if span > 0.0 => {
                    let ahead = dot(q, t) / span;
                    (ahead.atan2(dot(q, a)) / span).clamp(0.0, 1.0)
                }
                _ => 0.0,
            };
            frac = if k == 0 { 0.0 } else { frac.max(along) };
            if w[0] + k == w[1] {
                frac = 1.0;
            }
            params[w[0] + k] = (s as f64 + frac) / (m - 1) as f64;
        }
    }
    let measured = line.measure(&spline, &params)?;
    if !line.met(&measured) {
        return Ok(None);
    }
    let arc = line.finish(ArcCurve {
        spline,
        control_ll,
        rule: KnotRule::Uniform,
        measured,
        seam: Some("corner"),
        params,
    })?;
    Ok(Some(FittedArc {
        small_ring: Some(small_rings::Kept::Triangle),
        ..arc
    }))
}

/// The degree-1 spline on clamped uniform knots through `vertices`: a polyline written as its
/// vertices (a splice, a ring kept small).
fn polyline_spline(vertices: &[[f64; 3]]) -> Result<SphericalBSpline, EarthError> {
    let knots = crate::sphere::curve::bspline::clamped_uniform_knots(vertices.len(), 1);
    PointSet::try_from_rows(vertices)
        .and_then(|c| SphericalBSpline::try_new(1, knots, c))
        .map_err(|e| sphere_error(e, "", &[]))
}

/// The positions an arc is fitted through: an open arc's as they are; a closed one's started
/// at its sharpest corner (a C0 seam there costs nothing), with whether that corner is
/// smooth.
fn arc_rows(points_in: &[[f64; 3]], closed: bool) -> Result<(Vec<[f64; 3]>, bool), EarthError> {
    let mut rows = points_in.to_vec();
    let mut smooth_seam = false;
    if closed {
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
    Ok((rows, smooth_seam))
}

/// The share of the tolerance a coverage's arcs' greedy stabbing polyline is built to
/// ([`ToleranceOptions::stabbing_share`]): against the default 0.95, 247,984 stored numbers
/// instead of 262,158 on world-atlas countries-10m at 1 km, and no meeting left at 20 km
/// where 0.95 left four.
const COVERAGE_STABBING_SHARE: f64 = 0.99;

/// [`fit_arc`] on the arc's positions as [`arc_rows`] gives them.
fn fit_rows(
    rows: Vec<[f64; 3]>,
    closed: bool,
    smooth_seam: bool,
    tolerance: ToleranceRule,
    degree_cap: usize,
    parameterization: crate::sphere::Parameterization,
    job: &Job,
) -> Result<FittedArc, EarthError> {
    let line = ArcLine::new(&rows, closed, tolerance, job)?;
    let points = &line.points;
    let output = &job.output;
    let round = |x: f64| line.round(x);
    // Most arcs' best curve is a polyline, written as it is: it may aim at the tolerance less
    // its vertices' rounding, and fit its vertices to all of that first; smooth curves keep
    // the rest of the margin (world-atlas 50m countries at 1 km: 112,174 -> 97,716 stored
    // numbers, the TopoJSON 611 -> 541 KB).
    let mut target = tolerance.polyline_target_rad();
    // The first fit, at the job's tolerance (not a refit tightened where arcs met).
    let first_fit = match &job.operation {
        crate::earth::Operation::FitToTolerance { tolerance_m, .. } => {
            tolerance.tolerance_m >= *tolerance_m
        }
        _ => false,
    };
    let mut topts = ToleranceOptions {
        parameterization,
        max_control_points: Some(points.len()),
        pin_ends: true,
        measure_result: false,
        smooth_margin_rad: tolerance.polyline_target_rad() - tolerance.first_target_rad(),
        polyline_first_share: POLYLINE_FIRST_SHARE,
        // The first fit takes the greedy stabbing polyline first, as any line does, built to
        // 0.99 of the tolerance: on world-atlas countries-10m, TopoJSON, 2 threads, it fits
        // the coverage in 0.55 / 0.58 / 0.96 s instead of 0.92 / 1.02 / 1.66 s at 1 / 5 /
        // 20 km, for 4 % / 10 % / 5 % more stored numbers (mapshaper's file at 1 km holds
        // 30 % more). Refits, tightened where arcs met, keep the seeded least-squares
        // polyline: its vertices stay inside the band, where the greedy's sit on its edge and
        // meet their neighbours again (with the greedy there too, 5 km stored 118,710 numbers
        // and left a meeting; docs/speed.md, "tenth session").
        stabbing: first_fit,
        stabbing_share: COVERAGE_STABBING_SHARE,
        // Arcs are pieces of rings: probed for smooth degrees as rings are, however short.
        short_open_at_every_degree: false,
        ..ToleranceOptions::default()
    };
    topts.degrees.retain(|&p| p <= degree_cap);
    let measure = |spline: &SphericalBSpline, params: &[f64]| line.measure(spline, params);
    let met = |m: &Measured| line.met(m);
    let mut attempt = 0;
    // First a polyline aiming nearer the tolerance, kept when its rounded vertices still meet
    // it as written (rounding moves most vertices far less than its bound); smooth curves aim
    // where they did.
    let mut snap_try = tolerance.snap_first && tolerance.snap_target_rad() > target;
    if snap_try {
        target = tolerance.snap_target_rad();
        topts.smooth_margin_rad = target - tolerance.first_target_rad();
    }
    let curve = loop {
        let r =
            fit_to_tolerance(points, None, target, &topts).map_err(|e| sphere_error(e, "", &[]))?;
        let (rounded, ll) =
            round_spline_with(&r.spline, &round).map_err(|e| sphere_error(e, "", &[]))?;
        // A polyline: the fitter's own bound moved by the rounding where that is proven and
        // tight, as per feature; else measured afresh.
        let m = match line.moved_polyline(&r, &rounded) {
            Some(m) => m,
            None => measure(&rounded, &r.parameters)?,
        };
        let mut best = (rounded, ll, m, closed.then_some("corner"));
        if closed && smooth_seam && r.spline.degree() >= 2 {
            // A C1 seam where the ring is smooth, kept when the tolerance still holds.
            if let Ok(c1) = close_seam(&r.spline, true) {
                if let Ok((rc, llc)) = round_spline_with(&c1, &round) {
                    let m2 = measure(&rc, &r.parameters)?;
                    if met(&m2) {
                        best = (rc, llc, m2, Some("smooth"));
                    }
                }
            }
        }
        let curve = |(spline, control_ll, measured, seam): (_, _, Measured, _)| ArcCurve {
            spline,
            control_ll,
            rule: r.knot_rule,
            measured,
            seam,
            params: r.parameters.clone(),
        };
        if snap_try {
            snap_try = false;
            if met(&best.2) {
                break curve(best);
            }
            // Over as written: its vertices on the grid corners that keep its points closest
            // rather than the nearest ones, else the whole arc again at the target its
            // rounding bound allows.
            if let Some((snapped, ll)) = super::snap::snap_polyline(
                &r.spline,
                &best.1,
                points,
                &r.parameters,
                output.precision,
                tolerance.grid_multiple,
            ) {
                let m = measure(&snapped, &r.parameters)?;
                if met(&m) {
                    break curve((snapped, ll, m, best.3));
                }
            }
            target = tolerance.polyline_target_rad();
            topts.smooth_margin_rad = target - tolerance.first_target_rad();
            continue;
        }
        let worst = best.2.worst_rad();
        if let Some(lower) = tolerance.retry_target_rad(target, worst, r.tolerance_met, attempt) {
            target = lower;
            attempt += 1;
            continue;
        }
        break curve(best);
    };
    line.finish(curve)
}

/// A fitted arc's curve as returned, before it is sampled.
struct ArcCurve {
    /// The spline, its control points rounded.
    spline: SphericalBSpline,
    /// Its control points as written.
    control_ll: Vec<[f64; 2]>,
    rule: KnotRule,
    measured: Measured,
    seam: Option<&'static str>,
    /// The parameters of the arc's positions on it.
    params: Vec<f64>,
}

/// An arc's positions (as [`arc_rows`] gives them) and what measuring and writing a curve
/// fitted to them needs.
struct ArcLine<'a> {
    points: PointSet,
    closed: bool,
    tolerance: ToleranceRule,
    job: &'a Job,
    line_length: f64,
    /// Input vertices (a closed arc's first one once).
    n_in: usize,
}

impl<'a> ArcLine<'a> {
    fn new(
        rows: &[[f64; 3]],
        closed: bool,
        tolerance: ToleranceRule,
        job: &'a Job,
    ) -> Result<Self, EarthError> {
        let points = PointSet::try_from_rows(rows).map_err(|e| sphere_error(e, "", &[]))?;
        Ok(ArcLine {
            line_length: polyline_length(&points),
            n_in: if closed { rows.len() - 1 } else { rows.len() },
            points,
            closed,
            tolerance,
            job,
        })
    }

    /// A longitude or latitude on the grid the arc is written on: the rule's (a coverage's
    /// TopoJSON grid, or the decimal one when that cannot draw the coverage's arcs apart; see
    /// `fitting`).
    fn round(&self, x: f64) -> f64 {
        crate::earth::job::round_to_grid(x, self.job.output.precision, self.tolerance.grid_multiple)
    }

    /// The max error at the positions, and the two-way distance and the curve's length.
    fn measure(&self, spline: &SphericalBSpline, params: &[f64]) -> Result<Measured, EarthError> {
        let points = &self.points;
        let tw = two_way_distance(
            spline,
            points,
            params,
            &TwoWayOptions::default()
                .with_precision_rad(0.01 * self.tolerance.tol_rad)
                .with_max_evaluations(4_000_000 + 400 * points.len()),
        )
        .map_err(|e| sphere_error(e, "", &[]))?;
        Ok(self.measured_with(spline, params, tw.upper_rad, tw.curve_length_rad))
    }

    /// [`Self::measure`] of `rounded`, `fit`'s polyline with its vertices rounded, from the
    /// fitter's own two-way bound moved by the rounding
    /// ([`crate::earth::curve::moved_polyline_bound`]), to the precision [`Self::measure`]
    /// measures to: `None` where that is not proven (not a polyline, the bound not tight, arcs
    /// too long). Measuring each arc afresh was a fifth of a coverage's fitting on the 10m
    /// countries at 1 km (docs/speed.md, "tenth session").
    fn moved_polyline(
        &self,
        fit: &crate::sphere::ToleranceFit,
        rounded: &SphericalBSpline,
    ) -> Option<Measured> {
        let tw = crate::earth::curve::fitting::moved_polyline_bound(
            fit,
            rounded,
            0.01 * self.tolerance.tol_rad,
        )?;
        Some(self.measured_with(rounded, &fit.parameters, tw.upper_rad, tw.curve_length_rad))
    }

    /// The max error of `spline` at the positions (at `params`), with a two-way distance and
    /// a length known otherwise.
    fn measured_with(
        &self,
        spline: &SphericalBSpline,
        params: &[f64],
        two_way_rad: f64,
        curve_length_rad: f64,
    ) -> Measured {
        let errs = pointwise_errors(spline, &self.points, params);
        Measured {
            max_rad: errs.iter().fold(0.0f64, |a, &b| a.max(b)),
            two_way_rad,
            curve_length_rad,
        }
    }

    fn met(&self, m: &Measured) -> bool {
        self.tolerance
            .met(m.worst_rad(), m.curve_length_rad, self.line_length)
    }

    /// The arc as returned: `curve` sampled, its dense points rounded.
    fn finish(&self, curve: ArcCurve) -> Result<FittedArc, EarthError> {
        let ArcCurve {
            spline,
            control_ll,
            rule,
            measured,
            seam,
            params,
        } = curve;
        let (closed, job) = (self.closed, self.job);
        let round = |x: f64| self.round(x);
        let dense_margin = AUTO_DEVIATION_FRACTION * self.tolerance.tol_rad;
        // A closed arc is a whole ring: at least 4 positions (RFC 7946 §3.1.6).
        let sampling = match job.output.sampling {
            crate::earth::Sampling::Samples(n) if closed && n < 4 => {
                crate::earth::Sampling::Samples(4)
            }
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
        let mut dense_ll: Vec<[f64; 2]> = pts
            .iter()
            .map(|p| {
                let (lon, lat) = unit_to_lonlat(p);
                [round(lon), round(lat)]
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
        let met = self.met(&measured);

        Ok(FittedArc {
            stored_numbers: stored,
            knot_rule: rule,
            control_ll,
            dense: pts,
            dense_ll,
            max_error_rad: measured.max_rad,
            two_way_rad: measured.two_way_rad,
            curve_length_rad: measured.curve_length_rad,
            line_length_rad: self.line_length,
            tolerance_met: met,
            input_points: self.n_in,
            seam,
            sampling_deviation_rad: dense.max_deviation_rad,
            tolerance_rad: self.tolerance.tol_rad,
            spline,
            params,
            small_ring: None,
        })
    }
}

/// What is measured of an arc's curve as returned.
struct Measured {
    max_rad: f64,
    two_way_rad: f64,
    curve_length_rad: f64,
}

impl Measured {
    /// The larger of the max error and the two-way distance.
    fn worst_rad(&self) -> f64 {
        self.max_rad.max(self.two_way_rad)
    }
}

/// Whether a fitted arc meets `tolerance` (the job's, for an arc refitted tighter).
pub(super) fn tolerance_met_by(arc: &FittedArc, tolerance: &ToleranceRule) -> bool {
    tolerance.met(
        arc.max_error_rad.max(arc.two_way_rad),
        arc.curve_length_rad,
        arc.line_length_rad,
    )
}
