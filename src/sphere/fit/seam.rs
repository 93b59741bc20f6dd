//! Closed curves: a clamped spline whose two ends meet, smooth across the seam where the data
//! are smooth there.
//!
//! A closed curve is stored as an ordinary clamped spline (so every reader of spline documents
//! evaluates it unchanged) with `P_0 = P_{n−1} = S`. The end derivatives of a clamped spherical
//! B-spline are `C'(0) = p / a · log_S(P_1)` and `C'(1) = −p / b · log_S(P_{n−2})` with
//! `a = u_{p+1} − u_p` and `b = u_n − u_{n−1}` (the de Boor triangle reduces to one SLERP at
//! first order), so the curve is C1 across the seam exactly when
//! `log_S(P_1) / a = −log_S(P_{n−2}) / b`: S on the geodesic from P_{n−2} to P_1, splitting it in
//! the ratio b : a. That is the "equivalent construction" of a periodic spline used here: C1
//! (not C^(p−1)) at the seam, C^(p−1) elsewhere, and a readable clamped document.
//!
//! Where the data turn sharply at the seam (by at least
//! [`super::adaptive_knots::CORNER_ANGLE_RAD`], e.g. a polygon ring starting at a corner), the
//! seam is a corner instead: only `P_0 = P_{n−1}` (C0), as for corners elsewhere.
//!
//! [`fit_closed`] fits the line as an open curve with the given options, then alternates
//! GLS-PIA updates with [`close_seam`] (the projection onto the closed curves) so the control
//! points near the seam settle with the constraint in force.

use crate::sphere::curve::bspline::SphericalBSpline;
use crate::sphere::fit::adaptive_knots::CORNER_ANGLE_RAD;
use crate::sphere::fit::gls_pia::gls_pia_iteration_local;
use crate::sphere::fit::metrics::{pointwise_errors, ErrorSums};
use crate::sphere::fit::options::{FitOptions, FitReport, IterationError};
use crate::sphere::fit::solve::fit;
use crate::sphere::geometry::point::{exp_map, log_map, normalize, Dynamic, PointSet};
use crate::sphere::SphereError;

/// GLS-PIA updates with the seam constraint after the open fit.
pub const SEAM_ITERATIONS: usize = 30;

/// The seam updates stop once one lowers the RMS error by less than this share of it.
pub const SEAM_STAGNATION: f64 = 1e-3;

/// True when a closed line (last point = first) turns by less than the corner angle at its
/// seam: the direction into the last point and out of the first are nearly the same.
pub fn seam_is_smooth(points: &PointSet) -> bool {
    let n = points.len();
    if n < 4 {
        return false;
    }
    let rows = [
        points.get(n - 2).to_vec(),
        points.get(0).to_vec(),
        points.get(1).to_vec(),
    ];
    let three = PointSet::try_from_rows(&rows).expect("unit vectors");
    super::adaptive_knots::turning_angles(&three)[1] < CORNER_ANGLE_RAD
}

/// The closed curve nearest `s`: `P_0 = P_{n−1}` (their normalised mean) and, when `smooth`
/// and the degree is at least 2, the C1 seam condition, met by moving `P_1` and `P_{n−2}` the
/// least (weighted by the end spans) in the tangent plane at the seam point.
///
/// # Errors
/// When the result has (nearly) antipodal neighbouring control points.
pub fn close_seam(s: &SphericalBSpline, smooth: bool) -> Result<SphericalBSpline, SphereError> {
    // The control points stay flat (one copy) and are read back as row slices: as owned rows,
    // a vector each, closing a polyline ring at 10 m cost an allocation and a free per vertex
    // (the 10m land outlines: 263 M instructions of close_seam, 147 M of them those).
    let mut flat = s.control_points().as_flat().to_vec();
    let dim = s.dim();
    let n = flat.len() / dim;
    let mut seam: Vec<f64> = flat[..dim]
        .iter()
        .zip(&flat[(n - 1) * dim..])
        .map(|(a, b)| 0.5 * (a + b))
        .collect();
    if normalize(Dynamic(dim), &mut seam) <= 1e-12 {
        seam.copy_from_slice(&flat[..dim]);
    }
    flat[..dim].copy_from_slice(&seam);
    flat[(n - 1) * dim..].copy_from_slice(&seam);
    let p = s.degree();
    if smooth && p >= 2 && n >= 4 {
        let k = s.knots();
        let (a, b) = (k[p + 1] - k[p], k[n] - k[n - 1]);
        if a > 0.0 && b > 0.0 {
            let row = |i: usize| &flat[i * dim..(i + 1) * dim];
            let x1: Vec<f64> = log_map(&seam, row(1))?.iter().map(|v| v / a).collect();
            let x2: Vec<f64> = log_map(&seam, row(n - 2))?.iter().map(|v| -v / b).collect();
            let (wa, wb) = (a * a, b * b);
            let m: Vec<f64> = x1
                .iter()
                .zip(&x2)
                .map(|(u, v)| (wa * u + wb * v) / (wa + wb))
                .collect();
            let p1 = exp_map(&seam, &m.iter().map(|v| a * v).collect::<Vec<_>>())?;
            let p2 = exp_map(&seam, &m.iter().map(|v| -b * v).collect::<Vec<_>>())?;
            flat[dim..2 * dim].copy_from_slice(&p1);
            flat[(n - 2) * dim..(n - 1) * dim].copy_from_slice(&p2);
        }
    }
    let rows: Vec<&[f64]> = flat.chunks_exact(dim).collect();
    SphericalBSpline::try_new(p, s.knots().to_vec(), PointSet::try_from_rows(&rows)?)
}

/// Fits a closed line (`points` ending where they start) with `options`, then closes it
/// ([`close_fitted`]).
///
/// # Errors
/// As [`fit`].
pub fn fit_closed(points: &PointSet, options: &FitOptions) -> Result<FitReport, SphereError> {
    let open = fit(points, None, options)?;
    close_fitted(open, points, options)
}

/// Control points at each end, in multiples of `degree + 1`, that the seam iterations move.
/// The open fit has settled everything else and the seam's pull fades within a few spans: the
/// default fits of the 4,062 Natural Earth 10m land rings with the whole curve free and with
/// this window differ in 2 rings, by less than 0.01 % in RMS error. Only the window's data are
/// passed over, so closing a ring costs in proportion to the window, not the ring (the land
/// rings' default fit: 20.3 s to 12.7 s of CPU on 2 threads).
pub const SEAM_WINDOW_SPANS: usize = 8;

/// Closes an open fit of a closed line ([`close_seam`], smooth when [`seam_is_smooth`]) and
/// runs [`SEAM_ITERATIONS`] GLS-PIA updates of the control points near the seam
/// ([`SEAM_WINDOW_SPANS`]), each followed by the projection. Returns the closed curve with the
/// lowest RMS error measured; its metrics and history are those of closed curves only after
/// the open fit.
///
/// # Errors
/// When closing gives (nearly) antipodal neighbouring control points.
pub fn close_fitted(
    mut open: FitReport,
    points: &PointSet,
    options: &FitOptions,
) -> Result<FitReport, SphereError> {
    let smooth = seam_is_smooth(points);
    let params = open.parameters.clone();
    let mut current = close_seam(&open.spline, smooth)?;
    let n = current.control_points().len();
    let p = current.degree();
    let k = (SEAM_WINDOW_SPANS * (p + 1)).min(n / 2);
    // Control points i < k and i >= n - k move; a point at t depends on control points
    // span(t) - p ..= span(t), so the window's data are t < u_(k+p) and t >= u_(n-k).
    let knots = current.knots();
    let (lo_end, hi_start) = (knots[k + p], knots[n - k]);
    let window: Vec<usize> = if 2 * k < n {
        (0..params.len())
            .filter(|&j| params[j] < lo_end || params[j] >= hi_start)
            .collect()
    } else {
        (0..params.len()).collect()
    };
    let moving = |i: usize| 2 * k >= n || i < k || i >= n - k;
    let sub_points = PointSet::from_flat_unchecked(
        points.dim(),
        window
            .iter()
            .flat_map(|&j| points.get(j).to_vec())
            .collect(),
    );
    let sub_params: Vec<f64> = window.iter().map(|&j| params[j]).collect();
    // The errors outside the window do not change: measured once, merged with each pass
    // (nothing to measure when the window is the whole ring, as for every small ring). Closing
    // moved only control points inside the window, so outside it the open fit's last pass
    // measured them already (a pass over the whole ring saved: 6 % of the 10m land's default
    // fit).
    let mut all = Vec::new();
    let outside = if window.len() == params.len() {
        ErrorSums::default()
    } else {
        let mut sums = ErrorSums::default();
        let mut w = window.iter().peekable();
        all = if open.point_errors_rad.len() == params.len() {
            std::mem::take(&mut open.point_errors_rad)
        } else {
            pointwise_errors(&current, points, &params)
        };
        for (j, &e) in all.iter().enumerate() {
            if w.peek() == Some(&&j) {
                w.next();
            } else {
                sums.add(j, e);
            }
        }
        sums
    };
    let whole = |sub: ErrorSums| {
        let mut sums = outside;
        let mut sub = sub;
        sub.max_index = window.get(sub.max_index).copied().unwrap_or(0);
        sums.merge(&sub);
        sums.metrics()
    };
    let mut history = open.history.clone();
    // The best curve, its errors and its window's point errors.
    let mut best: Option<(SphericalBSpline, super::metrics::ErrorMetrics, Vec<f64>)> = None;
    let mut iterations = open.iterations;
    let mut previous_rms = f64::INFINITY;
    for _ in 0..SEAM_ITERATIONS {
        let before = current.clone();
        let (sub, sub_each) =
            gls_pia_iteration_local(&mut current, &sub_points, &sub_params, options.step, moving);
        let m = whole(sub);
        history.push(IterationError::of(&m));
        // An update that no longer pays ends them (after its projection).
        let stalled = m.rms_error_rad >= previous_rms * (1.0 - SEAM_STAGNATION);
        previous_rms = m.rms_error_rad;
        if best
            .as_ref()
            .is_none_or(|(_, b, _)| m.rms_error_rad < b.rms_error_rad)
        {
            best = Some((before, m, sub_each));
        }
        current = close_seam(&current, smooth)?;
        iterations += 1;
        if stalled {
            break;
        }
    }
    // Only the window's errors changed.
    let sub_each = pointwise_errors(&current, &sub_points, &sub_params);
    let m = {
        let mut sub = ErrorSums::default();
        for (j, &e) in sub_each.iter().enumerate() {
            sub.add(j, e);
        }
        whole(sub)
    };
    if best
        .as_ref()
        .is_none_or(|(_, b, _)| m.rms_error_rad < b.rms_error_rad)
    {
        best = Some((current, m, sub_each));
    }
    let (spline, metrics, sub_each) = best.expect("at least one measurement");
    // Every point's error: the window's as measured on the curve kept, the rest unchanged.
    let point_errors_rad = if all.is_empty() {
        sub_each
    } else {
        for (&j, e) in window.iter().zip(sub_each) {
            all[j] = e;
        }
        all
    };
    Ok(FitReport {
        spline,
        parameters: params,
        metrics,
        point_errors_rad,
        iterations,
        converged: open.converged,
        history,
        solver: open.solver,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sphere::fit::metrics::measure;

    fn ring(n: usize) -> PointSet {
        let rows: Vec<Vec<f64>> = (0..=n)
            .map(|i| {
                let a = std::f64::consts::TAU * (i % n) as f64 / n as f64;
                let (lon, lat) = (0.3 * a.cos(), 0.2 * a.sin() + 0.02 * (5.0 * a).sin());
                vec![lat.cos() * lon.cos(), lat.cos() * lon.sin(), lat.sin()]
            })
            .collect();
        PointSet::try_from_rows(&rows).unwrap()
    }

    #[test]
    fn a_smooth_ring_is_closed_and_c1_across_its_seam() {
        let pts = ring(80);
        assert!(seam_is_smooth(&pts));
        let r = fit_closed(&pts, &FitOptions::default().with_control_points(16)).unwrap();
        let s = &r.spline;
        let (a, b) = (s.evaluate(0.0), s.evaluate(1.0));
        assert_eq!(a, b, "the ends meet exactly");
        // One-sided derivatives at both ends agree (finite differences, h = 1e-6).
        let h = 1e-6;
        let d0: Vec<f64> = s
            .evaluate(h)
            .iter()
            .zip(&a)
            .map(|(x, y)| (x - y) / h)
            .collect();
        let d1: Vec<f64> = b
            .iter()
            .zip(&s.evaluate(1.0 - h))
            .map(|(x, y)| (x - y) / h)
            .collect();
        let norm = d0.iter().map(|x| x * x).sum::<f64>().sqrt();
        let diff = d0
            .iter()
            .zip(&d1)
            .map(|(x, y)| (x - y).powi(2))
            .sum::<f64>()
            .sqrt();
        assert!(
            diff < 1e-4 * norm,
            "C1 at the seam: |C'(0) - C'(1)| = {diff}, |C'| = {norm}"
        );
        // Closing costs little against the open fit of the same line.
        let open = fit(&pts, None, &FitOptions::default().with_control_points(16)).unwrap();
        assert!(
            r.metrics.max_error_rad < 1.5 * open.metrics.max_error_rad,
            "{} vs open {}",
            r.metrics.max_error_rad,
            open.metrics.max_error_rad
        );
    }

    #[test]
    fn a_ring_starting_at_a_corner_keeps_the_corner() {
        // A spherical triangle, starting at a vertex.
        let v = [[0.0, 0.0], [0.3, 0.0], [0.15, 0.25]];
        let mut rows = Vec::new();
        for k in 0..3 {
            let (a, b) = (v[k], v[(k + 1) % 3]);
            for j in 0..20 {
                let f = j as f64 / 20.0;
                let (lon, lat) = (a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1]));
                rows.push(vec![
                    lat.cos() * lon.cos(),
                    lat.cos() * lon.sin(),
                    lat.sin(),
                ]);
            }
        }
        rows.push(rows[0].clone());
        let pts = PointSet::try_from_rows(&rows).unwrap();
        assert!(!seam_is_smooth(&pts));
        let r = fit_closed(&pts, &FitOptions::default().with_control_points(20)).unwrap();
        assert_eq!(r.spline.evaluate(0.0), r.spline.evaluate(1.0));
    }

    #[test]
    fn a_long_ring_moves_only_its_seam_window_and_reports_whole_errors() {
        let pts = ring(600);
        let opts = FitOptions::default().with_control_points(120);
        let open = fit(&pts, None, &opts).unwrap();
        let closed = close_fitted(open.clone(), &pts, &opts).unwrap();
        let (a, b) = (closed.spline.evaluate(0.0), closed.spline.evaluate(1.0));
        assert_eq!(a, b, "the ends meet exactly");
        let k = SEAM_WINDOW_SPANS * (closed.spline.degree() + 1);
        let (o, c) = (open.spline.control_points(), closed.spline.control_points());
        // Outside the window only rounding (the projection renormalises every point).
        let moved = |i: usize| crate::sphere::geometry::point::angle_between(o.get(i), c.get(i));
        for i in k..c.len() - k {
            assert!(moved(i) < 1e-14, "control point {i} is outside the window");
        }
        assert!((0..k).any(|i| moved(i) > 1e-9));
        // The errors reported are the whole ring's, not the window's.
        let m = measure(&closed.spline, &pts, &closed.parameters);
        assert!((m.rms_error_rad - closed.metrics.rms_error_rad).abs() <= 1e-12 * m.rms_error_rad);
        assert_eq!(m.max_error_index, closed.metrics.max_error_index);
        // So are the point errors, which the knot refinement reads instead of measuring.
        assert_point_errors(&closed, &pts);
        let small = fit_closed(&ring(80), &FitOptions::default().with_control_points(16)).unwrap();
        assert_point_errors(&small, &ring(80));
    }

    /// `r.point_errors_rad` are the errors of `r.spline` at `r.parameters`.
    fn assert_point_errors(r: &FitReport, pts: &PointSet) {
        let want = pointwise_errors(&r.spline, pts, &r.parameters);
        assert_eq!(r.point_errors_rad.len(), want.len());
        for (j, (got, want)) in r.point_errors_rad.iter().zip(&want).enumerate() {
            assert!((got - want).abs() <= 1e-15, "point {j}: {got} vs {want}");
        }
    }
}
