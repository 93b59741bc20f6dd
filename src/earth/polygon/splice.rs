//! A line fitted to a tolerance as a polyline, refitted tighter around some of its segments
//! only ([`refit_line_around`]): the rest of it kept vertex for vertex.

use crate::earth::curve::fitting::{
    finish_tolerance_fit, reported_two_way, Prepared, ReportedTwoWay, ToleranceCurve,
};
use crate::earth::curve::fitting::{round_spline_rows, REPORT_TWO_WAY_PRECISION};
use crate::earth::curve::line::{LineRef, OutputSpec};
use crate::earth::curve::output::CurveOutput;
use crate::earth::curve::positions::{fits_closed, prepare_line, sphere_error};
use crate::earth::curve::tolerance_rule::ToleranceRule;
use crate::earth::error::EarthError;
use crate::sphere::compress::tolerance::{fit_to_tolerance, KnotRule, ToleranceOptions};
use crate::sphere::curve::bspline::clamped_uniform_knots;
use crate::sphere::curve::bspline::SphericalBSpline;
use crate::sphere::fit::options::FitOptions;
use crate::sphere::geometry::point::slerp;
use crate::sphere::geometry::point::{angle_between, PointSet};
use crate::sphere::SphereError;

/// Line `src`, fitted as `old` (a polyline kept by the fit, [`CurveOutput::kept`]), refitted to
/// `tolerance_m` only around its dense segments `at` (ascending: from point `i` to `i + 1`),
/// where it meets another line or itself: each run of such segments, with `margin` old
/// vertices on either side, is refitted as a polyline pinned at the old vertices that bound
/// it, through the positions between them, and spliced in; the rest is kept as it was, and the
/// whole is measured and reported as [`fit_line_to_tolerance`](crate::earth::curve::fitting::fit_line_to_tolerance) reports a fit to
/// `line_tolerance_m`, its `tolerance_m` the tighter one.
///
/// Refitting a whole ring for one meeting stored a long coast's every stretch at the tighter
/// tolerance: on world-atlas countries-10m at 5 km, rings fitted per feature stored 311,292
/// numbers with whole refits and 100,752 with none (docs/speed.md, "eighth session").
///
/// `None` when `old` kept no polyline, a window holds too few positions, or a window's refit
/// is not a polyline on uniform knots. A ring's seam (its first and last vertex) is never
/// moved: a window stops there.
///
/// # Errors
/// As [`fit_line_to_tolerance`](crate::earth::curve::fitting::fit_line_to_tolerance) (the line was fitted once already, so only a cancelled job).
pub fn refit_line_around(
    src: LineRef<'_>,
    options: &FitOptions,
    (line_tolerance_m, tolerance_m): (f64, f64),
    old: &CurveOutput,
    (at, margin): (&[usize], usize),
    out: OutputSpec<'_>,
) -> Result<Option<CurveOutput>, EarthError> {
    let Some(kept) = old.kept.as_deref() else {
        return Ok(None);
    };
    let pointer = src.pointer;
    let (line, distinct, timed) = prepare_line(src.value, pointer, src.closed, None)?;
    let closed = fits_closed(src.closed, &distinct, timed.as_ref());
    let src = LineRef { closed, ..src };
    let points = distinct.point_set();
    let n = points.len();
    let m = kept.control_ll.len();
    if at.is_empty() || kept.params.len() != n || at.iter().any(|&s| s + 1 >= m) {
        return Ok(None);
    }
    let err = |e: SphereError| sphere_error(e, pointer, &[]);
    let precision = out.output.precision;
    let rule = ToleranceRule::new(tolerance_m, precision);
    // The whole is measured and judged at the line's tolerance, which the stretches kept are
    // within (measuring them closer, to a share of the tighter one, was a tenth of the run at
    // 5 km on the 10m countries, proving nothing asked for).
    let line_rule = ToleranceRule::new(line_tolerance_m, precision);
    let (kept_rows, ctrl) = kept.rows().map_err(err)?;
    let vertices: Vec<[f64; 3]> = (0..m)
        .map(|k| {
            let c = ctrl.get(k);
            [c[0], c[1], c[2]]
        })
        .collect();
    let positions: Vec<[f64; 3]> = (0..n)
        .map(|i| {
            let p = points.get(i);
            [p[0], p[1], p[2]]
        })
        .collect();
    let topts = ToleranceOptions {
        degrees: vec![1],
        parameterization: options.parameterization,
        pin_ends: true,
        measure_result: false,
        ..ToleranceOptions::default()
    };
    let spliced = splice_windows(
        &vertices,
        &kept.params,
        &positions,
        (at, margin),
        |sub_rows| {
            let sub_points = PointSet::try_from_rows(&sub_rows).map_err(err)?;
            let sub = fit_to_tolerance(
                &sub_points,
                None,
                rule.polyline_target_rad(),
                &topts.clone().with_max_control_points(sub_rows.len()),
            )
            .map_err(err)?;
            let ms = sub.spline.control_points().len();
            if sub.spline.degree() != 1 || !sub.spline.has_clamped_uniform_knots() || ms < 2 {
                return Ok(None);
            }
            let (sub_spline, sub_ll, sub_rows_written) =
                round_spline_rows(&sub.spline, precision).map_err(err)?;
            let sub_ctrl = sub_spline.control_points();
            let interior = (1..ms - 1)
                .map(|k| {
                    let c = sub_ctrl.get(k);
                    ([c[0], c[1], c[2]], sub_ll[k], sub_rows_written[k])
                })
                .collect();
            Ok(Some(WindowFit {
                interior,
                params: sub.parameters,
            }))
        },
    )?;
    let Some(Splice {
        vertices: spliced,
        params,
        place,
        changed,
    }) = spliced
    else {
        return Ok(None);
    };
    let mut rows: Vec<[f64; 3]> = Vec::with_capacity(spliced.len());
    let mut control_ll: Vec<[f64; 2]> = Vec::with_capacity(spliced.len());
    let mut control_rows: Vec<[f64; 3]> = Vec::with_capacity(spliced.len());
    for v in spliced {
        let (unit, ll, row) = match v {
            Spliced::Old(k) => (vertices[k], kept.control_ll[k], kept_rows[k]),
            Spliced::New(new) => new,
        };
        rows.push(unit);
        control_ll.push(ll);
        control_rows.push(row);
    }
    let knots = clamped_uniform_knots(rows.len(), 1);
    let spline = PointSet::try_from_rows(&rows)
        .and_then(|c| SphericalBSpline::try_new(1, knots, c))
        .map_err(err)?;
    // Measuring the whole ring again was a tenth of the run at 5 km.
    let spliced = spliced_two_way(
        &rows,
        &points,
        (&place, &changed),
        kept.two_way_rad,
        line_rule.tol_rad,
    )?;
    let tw = if let Some(tw) = spliced {
        tw
    } else {
        reported_two_way(
            &spline,
            &points,
            &params,
            REPORT_TWO_WAY_PRECISION * line_rule.tol_rad,
            pointer,
        )?
    };
    let (mut out, _) = finish_tolerance_fit(
        Prepared {
            line: &line,
            distinct: &distinct,
            points: &points,
            time: None,
        },
        ToleranceCurve {
            spline,
            control_ll,
            control_rows,
            params,
            knot_rule: KnotRule::Uniform,
            degree: 1,
            tw,
            parameterization: options.parameterization,
        },
        &line_rule,
        src,
        out,
    )?;
    // What it was fitted to around the meetings.
    out.report
        .fields
        .insert("tolerance_m".into(), serde_json::json!(tolerance_m));
    Ok(Some(out))
}

/// A polyline's vertex after a splice ([`splice_windows`]): an old one kept, or a window's new
/// one.
pub(crate) enum Spliced<V> {
    Old(usize),
    New(V),
}

/// A window's refit ([`splice_windows`]): its interior vertices (its ends are the old vertices
/// that bound it) and the parameter of each row of the window's line on it.
pub(crate) struct WindowFit<V> {
    pub(crate) interior: Vec<V>,
    pub(crate) params: Vec<f64>,
}

/// A polyline spliced ([`splice_windows`]).
pub(crate) struct Splice<V> {
    pub(crate) vertices: Vec<Spliced<V>>,
    /// Each position's parameter on the new polyline (uniform knots), non-decreasing, the ends
    /// at 0 and 1.
    pub(crate) params: Vec<f64>,
    /// Each position's place along it: vertex index plus the share of the next segment.
    pub(crate) place: Vec<f64>,
    /// Each window's positions with one on either side (first, last): the input segments
    /// whose stretch of the polyline changed.
    pub(crate) changed: Vec<(usize, usize)>,
}

/// A polyline (`vertices`, on uniform knots; `positions` at `params` on it) refitted around its
/// segments `at` (ascending; segment `i` from vertex `i` to `i + 1`) only: each run of them,
/// with `margin` old vertices on either side, is a window whose line (its first vertex, the
/// positions between, each once, its last vertex) `fit_window` refits pinned at its ends; the
/// rest is kept. Shared by rings fitted per feature ([`refit_line_around`]) and a coverage's
/// arcs (`topology`). `None` when a segment is past the last, a window holds no position, or
/// `fit_window` gives `None`.
pub(crate) fn splice_windows<V>(
    vertices: &[[f64; 3]],
    params: &[f64],
    positions: &[[f64; 3]],
    (at, margin): (&[usize], usize),
    mut fit_window: impl FnMut(Vec<[f64; 3]>) -> Result<Option<WindowFit<V>>, EarthError>,
) -> Result<Option<Splice<V>>, EarthError> {
    let (m, n) = (vertices.len(), positions.len());
    if at.is_empty() || m < 2 || params.len() != n || at.iter().any(|&s| s + 1 >= m) {
        return Ok(None);
    }
    // The windows of old vertices [lo, hi] refitted, merged where they overlap.
    let mut windows: Vec<(usize, usize)> = Vec::new();
    for &s in at {
        let (lo, hi) = (s.saturating_sub(margin), (s + 1 + margin).min(m - 1));
        match windows.last_mut() {
            Some(w) if lo <= w.1 => w.1 = w.1.max(hi),
            _ => windows.push((lo, hi)),
        }
    }
    // Each position's place along the old polyline.
    let last = (m - 1) as f64;
    let pos: Vec<f64> = params.iter().map(|t| t * last).collect();
    let mut out: Vec<Spliced<V>> = Vec::with_capacity(m);
    let mut place = vec![0.0; n];
    let mut changed: Vec<(usize, usize)> = Vec::with_capacity(windows.len());
    // New place minus old place, past the windows spliced so far.
    let mut shift = 0.0;
    let (mut v, mut r) = (0, 0);
    for &(lo, hi) in &windows {
        out.extend((v..lo).map(Spliced::Old));
        while r < n && pos[r] <= lo as f64 {
            place[r] = pos[r] + shift;
            r += 1;
        }
        let start = r;
        while r < n && pos[r] < hi as f64 {
            r += 1;
        }
        let (first, end) = (vertices[lo], vertices[hi]);
        let mut sub_rows = vec![first];
        let mut sub_of = Vec::with_capacity(r - start);
        for p in &positions[start..r] {
            if p != sub_rows.last().expect("the first vertex") && *p != end {
                sub_rows.push(*p);
            }
            sub_of.push(sub_rows.len() - 1);
        }
        sub_rows.push(end);
        if sub_rows.len() < 3 {
            return Ok(None);
        }
        let rows_in = sub_rows.len();
        let Some(WindowFit { interior, params }) = fit_window(sub_rows)? else {
            return Ok(None);
        };
        if params.len() != rows_in {
            return Ok(None);
        }
        let base = out.len() as f64;
        // The window's ends are the old vertices exactly; its interior is the refit's.
        out.push(Spliced::Old(lo));
        let sub_last = (interior.len() + 1) as f64;
        out.extend(interior.into_iter().map(Spliced::New));
        for (i, &k) in (start..r).zip(&sub_of) {
            place[i] = base + params[k] * sub_last;
        }
        shift = base + sub_last - hi as f64;
        v = hi;
        changed.push((start.saturating_sub(1), r.min(n - 1)));
    }
    out.extend((v..m).map(Spliced::Old));
    while r < n {
        place[r] = pos[r] + shift;
        r += 1;
    }
    let new_last = (out.len() - 1) as f64;
    let mut params: Vec<f64> = place
        .iter()
        .map(|p| (p / new_last).clamp(0.0, 1.0))
        .collect();
    params[0] = 0.0;
    params[n - 1] = 1.0;
    for i in 1..n {
        params[i] = params[i].max(params[i - 1]);
    }
    Ok(Some(Splice {
        vertices: out,
        params,
        place,
        changed,
    }))
}

/// The two-way distance of a spliced polyline `rows` from the line's `points` (each position's
/// place along `rows` in `place`) and its length: the old curve's bound `old_upper_rad` holds
/// for the stretches kept (each input segment there has the same stretch of curve as before),
/// and the `changed` stretches (first and last position of each) are measured alone
/// ([`stretch_two_way`]). `None` when a changed stretch is a point: the caller measures the
/// whole line. Rings fitted per feature and a coverage's arcs are spliced and measured so.
pub(crate) fn spliced_two_way(
    rows: &[[f64; 3]],
    points: &PointSet,
    (place, changed): (&[f64], &[(usize, usize)]),
    old_upper_rad: f64,
    tol_rad: f64,
) -> Result<Option<ReportedTwoWay>, EarthError> {
    let mut upper = old_upper_rad;
    for &(first, last) in changed {
        let Some(d) = stretch_two_way(rows, points, place, (first, last), tol_rad)? else {
            return Ok(None);
        };
        upper = upper.max(d);
    }
    Ok(Some(ReportedTwoWay {
        upper_rad: upper,
        curve_length_rad: rows.windows(2).map(|w| angle_between(&w[0], &w[1])).sum(),
    }))
}

/// The two-way distance between the positions `first ..= last` of a line and the stretch of
/// the polyline `rows` they span (each position's place along it in `place`: vertex index plus
/// the share of the next segment), to [`REPORT_TWO_WAY_PRECISION`] of `tol_rad`. The stretch
/// is cut at the first and last positions' places, with knots at its vertices' places, so each
/// position keeps its point on the curve. `None` when the stretch is a point.
fn stretch_two_way(
    rows: &[[f64; 3]],
    points: &PointSet,
    place: &[f64],
    (first, last): (usize, usize),
    tol_rad: f64,
) -> Result<Option<f64>, EarthError> {
    let err = |e: SphereError| sphere_error(e, "", &[]);
    let (lo, hi) = (place[first], place[last]);
    if hi <= lo {
        return Ok(None);
    }
    let at = |x: f64| -> Result<[f64; 3], EarthError> {
        let k = (x.floor() as usize).min(rows.len() - 1);
        if k + 1 == rows.len() || x == k as f64 {
            return Ok(rows[k]);
        }
        let p = slerp(&rows[k], &rows[k + 1], x - k as f64).map_err(err)?;
        Ok([p[0], p[1], p[2]])
    };
    let mut verts = vec![at(lo)?];
    let mut knots = vec![0.0, 0.0];
    let span = hi - lo;
    for k in (lo.floor() as usize + 1)..rows.len() {
        if k as f64 >= hi {
            break;
        }
        verts.push(rows[k]);
        knots.push((k as f64 - lo) / span);
    }
    verts.push(at(hi)?);
    knots.push(1.0);
    knots.push(1.0);
    let mut params: Vec<f64> = place[first..=last]
        .iter()
        .map(|x| ((x - lo) / span).clamp(0.0, 1.0))
        .collect();
    params[0] = 0.0;
    *params.last_mut().expect("two positions") = 1.0;
    let sub: Vec<[f64; 3]> = (first..=last)
        .map(|i| {
            let p = points.get(i);
            [p[0], p[1], p[2]]
        })
        .collect();
    let sub = PointSet::try_from_rows(&sub).map_err(err)?;
    let curve = PointSet::try_from_rows(&verts)
        .and_then(|c| SphericalBSpline::try_new(1, knots, c))
        .map_err(err)?;
    let tw = reported_two_way(
        &curve,
        &sub,
        &params,
        REPORT_TWO_WAY_PRECISION * tol_rad,
        "",
    )?;
    Ok(Some(tw.upper_rad))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::earth::curve::fitting::fit_line_to_tolerance;
    use crate::earth::curve::output::KeptPolyline;
    use crate::earth::job::Limits;
    use crate::earth::job::OutputOptions;
    use crate::earth::lonlat::lonlat_to_unit;
    use crate::earth::lonlat::m_to_rad;
    use crate::earth::lonlat::rad_to_m;
    use crate::sphere::certify::two_way::two_way_distance;
    use crate::sphere::certify::two_way::TwoWayOptions;
    use crate::sphere::geometry::arc::distance_to_arc;
    use serde_json::Value;

    /// A jagged island about 300 km across, as a GeoJSON ring.
    fn island() -> Value {
        let n = 900;
        let ring: Vec<[f64; 2]> = (0..=n)
            .map(|i| {
                let a = std::f64::consts::TAU * (i % n) as f64 / n as f64;
                let r = 1.3 + 0.08 * (9.0 * a).sin() + 0.01 * ((i % n) as f64 * 2.3).sin();
                [20.0 + r * a.cos(), 50.0 + 0.7 * r * a.sin()]
            })
            .collect();
        serde_json::json!(ring)
    }

    /// The kept polyline as a spline.
    fn spline_of(kept: &KeptPolyline) -> SphericalBSpline {
        let (_, ctrl) = kept.rows().unwrap();
        SphericalBSpline::try_new(1, clamped_uniform_knots(ctrl.len(), 1), ctrl).unwrap()
    }

    /// The island as a Polygon's first ring.
    fn ring_ref(value: &Value) -> LineRef<'_> {
        LineRef {
            value,
            pointer: "/coordinates/0",
            path: &[0],
            closed: true,
        }
    }

    static OUTPUT: std::sync::LazyLock<OutputOptions> =
        std::sync::LazyLock::new(OutputOptions::default);
    static LIMITS: std::sync::LazyLock<Limits> = std::sync::LazyLock::new(Limits::default);

    /// The default output and limits.
    fn spec() -> OutputSpec<'static> {
        OutputSpec {
            output: &OUTPUT,
            limits: &LIMITS,
        }
    }

    fn field(out: &CurveOutput, k: &str) -> f64 {
        out.report.fields[k].as_f64().unwrap()
    }

    #[test]
    fn a_ring_is_refitted_only_around_where_it_meets() {
        // The island fitted at 300 m as a polyline, then refitted at 75 m around two of its
        // segments: its vertices outside the two windows stay as they were, the windows'
        // positions are within 75 m of the new ring, the whole ring within 300 m, and the
        // report says so.
        let value = island();
        let src = ring_ref(&value);
        let out = spec();
        let options = FitOptions::faithful();
        let old = fit_line_to_tolerance(src, &options, 300.0, None, out).unwrap();
        let kept = old.kept.as_deref().expect("a polyline is kept");
        let m = kept.control_ll.len();
        assert!(m > 40, "{m} vertices");
        assert_eq!(old.points.len(), m);
        let (s1, s2) = (m / 4, m / 2);
        let new = refit_line_around(src, &options, (300.0, 75.0), &old, (&[s1, s2], 1), out)
            .unwrap()
            .expect("a polyline written as its vertices is refitted around its segments");
        let new_ll = &new
            .kept
            .as_deref()
            .expect("the splice is kept too")
            .control_ll;
        let n = new_ll.len();
        // The windows are old vertices s - 1 ..= s + 2, their ends kept.
        assert_eq!(new_ll[..s1], kept.control_ll[..s1]);
        assert_eq!(new_ll[n - (m - s2 - 2)..], kept.control_ll[s2 + 2..]);
        assert_ne!(new_ll, &kept.control_ll);
        assert_eq!(new_ll.first(), new_ll.last(), "the ring stays closed");
        assert_eq!(new.points.len(), n, "written as its vertices");
        assert!(field(&new, "max_error_m") <= 300.0);
        assert!(field(&new, "two_way_distance_m") <= 300.0);
        assert_eq!(new.report.fields["tolerance_m"], serde_json::json!(75.0));
        assert_eq!(new.report.stored_numbers, 2 * n + 1);
        // Its reported two-way distance bounds the spliced ring's, measured whole.
        let new_kept = new.kept.as_deref().unwrap();
        let ring: Vec<[f64; 2]> = serde_json::from_value(value.clone()).unwrap();
        let all: Vec<[f64; 3]> = ring.iter().map(|p| lonlat_to_unit(p[0], p[1])).collect();
        let measured = two_way_distance(
            &spline_of(new_kept),
            &PointSet::try_from_rows(&all).unwrap(),
            &new_kept.params,
            &TwoWayOptions::default().with_precision_rad(m_to_rad(0.1)),
        )
        .unwrap();
        assert!(new_kept.two_way_rad >= measured.lower_rad);
        assert!(field(&new, "two_way_distance_m") >= rad_to_m(measured.lower_rad));
        // The positions between the first window's ends are within 75 m of the new ring.
        let (lo, hi) = (s1 - 1, s1 + 2);
        let inside: Vec<usize> = (0..kept.params.len())
            .filter(|&i| {
                let p = kept.params[i] * (m - 1) as f64;
                p > lo as f64 && p < hi as f64
            })
            .collect();
        assert!(inside.len() >= 2, "{} positions", inside.len());
        let ring: Vec<[f64; 2]> = serde_json::from_value(value.clone()).unwrap();
        let distinct: Vec<[f64; 3]> = ring[..ring.len() - 1]
            .iter()
            .map(|p| lonlat_to_unit(p[0], p[1]))
            .collect();
        for i in inside {
            let d = new
                .points
                .windows(2)
                .map(|w| distance_to_arc(&distinct[i], &w[0], &w[1]))
                .fold(f64::INFINITY, f64::min);
            assert!(d <= m_to_rad(75.0) * 1.01, "{} m", rad_to_m(d));
        }
    }

    #[test]
    fn a_stretch_is_measured_as_the_whole_line_measures_it() {
        // The two-way distance of positions a ..= b from the stretch of the fitted polyline they
        // span, cut at fractional places, against the whole line's measurement segment by
        // segment (each to 1 % of the tolerance).
        let value = island();
        let src = ring_ref(&value);
        let out = spec();
        let old = fit_line_to_tolerance(src, &FitOptions::faithful(), 300.0, None, out).unwrap();
        let kept = old.kept.as_deref().unwrap();
        let spline = spline_of(kept);
        let ctrl = spline.control_points();
        let rows: Vec<[f64; 3]> = (0..ctrl.len())
            .map(|k| [ctrl.get(k)[0], ctrl.get(k)[1], ctrl.get(k)[2]])
            .collect();
        let ring: Vec<[f64; 2]> = serde_json::from_value(value).unwrap();
        let distinct: Vec<[f64; 3]> = ring.iter().map(|p| lonlat_to_unit(p[0], p[1])).collect();
        let points = PointSet::try_from_rows(&distinct).unwrap();
        assert_eq!(points.len(), kept.params.len());
        let tol = m_to_rad(300.0);
        let whole = two_way_distance(
            &spline,
            &points,
            &kept.params,
            &TwoWayOptions::default().with_precision_rad(1e-3 * tol),
        )
        .unwrap();
        let place: Vec<f64> = kept
            .params
            .iter()
            .map(|t| t * (rows.len() - 1) as f64)
            .collect();
        let n = points.len();
        for (a, b) in [(0, n - 1), (10, 40), (101, 102), (500, 899)] {
            // Cut inside a segment: the first position from `a` on that is not a vertex.
            let a = (a..n - 1)
                .find(|&i| i == 0 || place[i].fract() != 0.0)
                .expect("a position between vertices");
            let b = b.max(a + 1);
            let d = stretch_two_way(&rows, &points, &place, (a, b), tol)
                .unwrap()
                .unwrap();
            let expect = whole.segment_upper_rad[a..b]
                .iter()
                .fold(0.0f64, |m, &x| m.max(x));
            assert!(
                (d - expect).abs() <= 0.03 * tol,
                "{a}..={b}: {} m against {} m",
                rad_to_m(d),
                rad_to_m(expect)
            );
        }
    }

    #[test]
    fn a_fit_that_is_not_a_polyline_is_not_spliced() {
        // Nothing kept (a fit in time, a smooth curve, an interpolation): the caller refits
        // whole.
        let value = island();
        let src = ring_ref(&value);
        let out = spec();
        let options = FitOptions::faithful();
        let mut old = fit_line_to_tolerance(src, &options, 300.0, None, out).unwrap();
        assert!(
            refit_line_around(src, &options, (300.0, 75.0), &old, (&[], 1), out)
                .unwrap()
                .is_none()
        );
        old.kept = None;
        assert!(
            refit_line_around(src, &options, (300.0, 75.0), &old, (&[3], 1), out)
                .unwrap()
                .is_none()
        );
    }
}
