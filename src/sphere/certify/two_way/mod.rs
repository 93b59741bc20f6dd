//! The certified two-way distance between a curve on S^n and a polyline of great-circle arcs,
//! with the polyline's points matched to the curve in order.
//!
//! # What is measured
//! Points `q_0 .. q_{n-1}` (the polyline's vertices, joined by minor great-circle arcs
//! `s_j = q_j q_{j+1}`) are matched to non-decreasing curve parameters `t_0 <= .. <= t_{n-1}`
//! (the fitter's foot points, or given times). The **two-way distance** is
//!
//! ```text
//! D = max( max_j d(q_j, C(t_j)),  max_j H(s_j, C([t_j, t_{j+1}])) )
//! ```
//!
//! where H is the Hausdorff distance (both ways) between the arc s_j and the curve piece
//! between the matched parameters (the first piece starts at the curve's start, the last ends
//! at its end). So every point of the polyline, not only its vertices, is within D of the curve
//! and every point of the curve within D of the polyline, and the matching runs in order: a
//! stretch of line cannot be "covered" by a distant loop of the curve. D is never smaller than
//! the plain Hausdorff distance between polyline and curve, nor than the vertex error.
//!
//! # How it is certified
//! [`two_way_distance`] returns an upper bound (`upper_rad`) proven by adaptive subdivision,
//! never a fixed sample count, and a lower bound (`lower_rad`) attained by samples; it stops
//! when the two are within `precision_rad`. Curve to arc: on a parameter interval the curve's
//! speed is bounded ([`SphericalCurve::speed_bound`]), so the distance to the arc is Lipschitz
//! and also the piece stays in a spherical ellipse around its chord
//! ([`super::bounds::ellipse_deviation`]); intervals whose bound is too high are halved. Arc
//! to curve: the distance from a point of the arc to the nearest curve sample has a closed form
//! along the arc, so the largest distance to the sample set is bounded exactly; where it is too
//! high, curve samples are added nearby. The proofs are in `docs/certified-distance.md`.
//!
//! A curve that is a chain of great-circle arcs (a degree-1 B-spline,
//! [`SphericalCurve::as_polyline`]) is bounded in closed form instead, arc by arc
//! (`certify::polyline`), and only segments where that is not tight go the general way.
//!
//! Cost: about (curve length / D) · log(D / precision) curve evaluations, in parallel over the
//! polyline's segments; for a polyline curve, a few arc-to-arc bounds per segment.

use crate::sphere::certify::bounds::{
    acceleration_deviation, arc_to_arc_sup, ellipse_deviation, ROUNDING_SLACK_RAD,
};
use crate::sphere::curve::SphericalCurve;
use crate::sphere::geometry::arc::ArcFrame;
use crate::sphere::geometry::point::{angle_between, dot, Dynamic, PointSet};
use crate::sphere::SphereError;
use rayon::prelude::*;
use std::f64::consts::PI;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

/// How precisely, and at what cost at most, [`two_way_distance`] works.
#[derive(Clone, Debug, PartialEq)]
pub struct TwoWayOptions {
    /// Stop refining once the upper bound is within this of the lower bound (radians).
    pub precision_rad: f64,
    /// Most curve evaluations in all. When they run out the bound returned is still an upper
    /// bound, only a looser one (`budget_exhausted` says so).
    pub max_evaluations: usize,
    /// Decide against this level instead of measuring precisely: intervals whose bound is at
    /// most the level are accepted as they are, and the work stops as soon as a sample lies
    /// farther than the level (`exceeded`). A fitter asking "is D <= T?" needs no more.
    pub decide_rad: Option<f64>,
}

impl Default for TwoWayOptions {
    fn default() -> Self {
        TwoWayOptions {
            precision_rad: 1e-8,
            max_evaluations: 20_000_000,
            decide_rad: None,
        }
    }
}

impl TwoWayOptions {
    with_fields! {
        /// Sets the precision (radians).
        with_precision_rad(precision_rad: f64);
        /// Sets the evaluation budget.
        with_max_evaluations(max_evaluations: usize);
    }
    /// Decides "D <= level?" instead of measuring D (see [`TwoWayOptions::decide_rad`]).
    pub fn deciding(mut self, level_rad: f64) -> Self {
        self.decide_rad = Some(level_rad);
        self
    }
}

/// The result of [`two_way_distance`]; all distances in radians.
#[derive(Clone, Debug, PartialEq)]
pub struct TwoWayDistance {
    /// Proven upper bound of the two-way distance D.
    pub upper_rad: f64,
    /// A lower bound of D, attained at a sample.
    pub lower_rad: f64,
    /// The largest vertex error d(q_j, C(t_j)).
    pub vertex_max_rad: f64,
    /// Upper bound of the curve-to-polyline part (every curve point is this close to its arc).
    pub curve_to_line_rad: f64,
    /// Upper bound of the polyline-to-curve part.
    pub line_to_curve_rad: f64,
    /// Per segment j (q_j to q_{j+1}): an upper bound of H(s_j, C([t_j, t_{j+1}])) and of the
    /// two vertex errors at its ends.
    pub segment_upper_rad: Vec<f64>,
    /// Length of the curve, as the sum of chords between all samples taken (a lower bound,
    /// accurate to the sampling).
    pub curve_length_rad: f64,
    /// Curve evaluations made.
    pub evaluations: usize,
    /// The evaluation budget ran out (the bound holds, but may be loose).
    pub budget_exhausted: bool,
    /// Deciding ([`TwoWayOptions::decide_rad`]): a sample lies farther than the level, so D
    /// exceeds it; the work stopped there and `upper_rad` is only the trivial bound (pi).
    pub exceeded: bool,
}

/// The length of a polyline (sum of its great-circle arcs), radians.
pub fn polyline_length(points: &PointSet) -> f64 {
    (1..points.len())
        .map(|i| angle_between(points.get(i - 1), points.get(i)))
        .sum()
}

/// Certified two-way distance between `curve` and the polyline through `points`, matched at
/// `params` (one per point, non-decreasing, inside the curve's domain; see the module docs).
///
/// # Errors
/// [`SphereError::Cancelled`] when the token entered on the calling thread is cancelled
/// ([`crate::sphere::cancel`]); [`SphereError::TooFewPoints`] for fewer than 2 points,
/// [`SphereError::DimensionMismatch`]
/// when the points' dimension is not the curve's, [`SphereError::InvalidParameters`] for a
/// wrong count, non-finite or decreasing parameters.
///
/// # Example
/// ```
/// use spherefit::sphere::certify::two_way::{two_way_distance, TwoWayOptions};
/// use spherefit::sphere::{PointSet, SphericalBSpline};
/// // A great-circle arc as a degree-1 spline, and points 1e-4 rad north of it.
/// let ctrl = PointSet::try_from_rows(&[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]).unwrap();
/// let arc = SphericalBSpline::try_new(1, vec![0.0, 0.0, 1.0, 1.0], ctrl).unwrap();
/// let h = 1e-4_f64;
/// let rows: Vec<[f64; 3]> = (0..5).map(|i| {
///     let a = i as f64 / 4.0 * std::f64::consts::FRAC_PI_2;
///     [h.cos() * a.cos(), h.cos() * a.sin(), h.sin()]
/// }).collect();
/// let pts = PointSet::try_from_rows(&rows).unwrap();
/// let t = [0.0, 0.25, 0.5, 0.75, 1.0];
/// let d = two_way_distance(&arc, &pts, &t, &TwoWayOptions::default()).unwrap();
/// // The points are 1e-4 off the arc, but the great-circle segments between them bulge
/// // towards the pole: 1e-4 / cos(11.25 degrees) at their middles.
/// let bulge = 1e-4 / (std::f64::consts::PI / 16.0).cos();
/// assert!(d.upper_rad >= bulge - 1e-12 && d.upper_rad < bulge + 2e-8);
/// assert!(d.upper_rad - d.lower_rad <= 2e-8);
/// ```
pub fn two_way_distance(
    curve: &dyn SphericalCurve,
    points: &PointSet,
    params: &[f64],
    options: &TwoWayOptions,
) -> Result<TwoWayDistance, SphereError> {
    let n = points.len();
    if n < 2 {
        return Err(SphereError::TooFewPoints { got: n, need: 2 });
    }
    let dim = curve.dim();
    if points.dim() != dim {
        return Err(SphereError::DimensionMismatch {
            index: 0,
            expected: dim,
            got: points.dim(),
        });
    }
    if params.len() != n {
        return Err(SphereError::InvalidParameters {
            reason: format!("got {} parameters for {n} points", params.len()),
        });
    }
    if let Some(i) = params.iter().position(|t| !t.is_finite()) {
        return Err(SphereError::InvalidParameters {
            reason: format!("parameter {i} is not a finite number"),
        });
    }
    if let Some(i) = (1..n).find(|&i| params[i] < params[i - 1]) {
        return Err(SphereError::InvalidParameters {
            reason: format!("parameter {i} is smaller than parameter {}", i - 1),
        });
    }
    let (lo, hi) = curve.domain();
    let ts: Vec<f64> = params.iter().map(|t| t.clamp(lo, hi)).collect();
    let vertex_pts = curve.evaluate_many(&ts);
    let errs: Vec<f64> = (0..n)
        .map(|j| angle_between(points.get(j), vertex_pts.get(j)))
        .collect();
    let vertex_max = errs.iter().copied().fold(0.0, f64::max);
    let breaks = curve.breaks();
    let budget = AtomicUsize::new(options.max_evaluations.saturating_sub(n));
    let eps = options.precision_rad.max(ROUNDING_SLACK_RAD);
    let decide = options.decide_rad.unwrap_or(f64::INFINITY);
    let stop = AtomicBool::new(vertex_max > decide);
    // The caller's cancellation token, for the worker threads.
    let token = crate::sphere::cancel::current();
    let domain_width = (hi - lo).abs().max(hi.abs()).max(lo.abs()).max(1.0);
    let general = |j: usize| -> Piece {
        let ta = if j == 0 { lo } else { ts[j] };
        let tb = if j + 2 == n { hi } else { ts[j + 1] };
        let (ca, cb) = (
            curve.evaluate_at(ta),
            if tb == ts[j + 1] {
                vertex_pts.get(j + 1).to_vec()
            } else {
                curve.evaluate_at(tb)
            },
        );
        let mut extra = Vec::new();
        if ta != ts[j] {
            extra.push((ts[j], vertex_pts.get(j).to_vec()));
        }
        piece_bound(
            curve,
            PieceInput {
                qa: points.get(j),
                qb: points.get(j + 1),
                ta,
                tb,
                ca,
                cb,
                extra,
                breaks: &breaks,
                level0: vertex_max,
                eps,
                budget: &budget,
                decide,
                stop: &stop,
                domain_width,
                token: &token,
            },
        )
    };
    let pieces: Vec<Piece> = match curve.as_polyline() {
        Some((vparams, vertices)) => {
            let levels = super::polyline::Levels {
                level0: vertex_max,
                eps,
                decide,
            };
            let last = vertices.len() - 1;
            (0..n - 1)
                .into_par_iter()
                .with_min_len(POLYLINE_SEGMENTS_PER_JOB)
                .map(|j| {
                    if stop.load(Ordering::Relaxed) {
                        return Piece::default();
                    }
                    let ta = if j == 0 { lo } else { ts[j] };
                    let tb = if j + 2 == n { hi } else { ts[j + 1] };
                    let (a_known, b_known) = (ta == ts[j], tb == ts[j + 1]);
                    let seg = super::polyline::Segment {
                        qa: points.get(j),
                        qb: points.get(j + 1),
                        ta,
                        tb,
                        ca: if a_known {
                            vertex_pts.get(j)
                        } else {
                            vertices.get(0)
                        },
                        cb: if b_known {
                            vertex_pts.get(j + 1)
                        } else {
                            vertices.get(last)
                        },
                        ea: a_known.then_some(errs[j]),
                        eb: b_known.then_some(errs[j + 1]),
                        extra: (!a_known).then(|| (ts[j], vertex_pts.get(j))),
                    };
                    let piece = super::polyline::piece(vparams, vertices, &seg, &levels)
                        .unwrap_or_else(|| general(j));
                    if piece.lower > decide {
                        stop.store(true, Ordering::Relaxed);
                    }
                    piece
                })
                .collect()
        }
        None => (0..n - 1).into_par_iter().map(general).collect(),
    };
    let mut out = TwoWayDistance {
        upper_rad: vertex_max,
        lower_rad: vertex_max,
        vertex_max_rad: vertex_max,
        curve_to_line_rad: 0.0,
        line_to_curve_rad: 0.0,
        segment_upper_rad: Vec::with_capacity(n - 1),
        curve_length_rad: 0.0,
        evaluations: n,
        budget_exhausted: false,
        exceeded: false,
    };
    for (j, p) in pieces.iter().enumerate() {
        out.curve_to_line_rad = out.curve_to_line_rad.max(p.upper1);
        out.line_to_curve_rad = out.line_to_curve_rad.max(p.upper2);
        out.lower_rad = out.lower_rad.max(p.lower);
        let s = p.upper1.max(p.upper2).max(errs[j]).max(errs[j + 1]);
        out.segment_upper_rad.push(s);
        out.upper_rad = out.upper_rad.max(s);
        out.curve_length_rad += p.length;
        out.evaluations += p.evaluations;
        out.budget_exhausted |= p.exhausted;
    }
    token.check()?;
    if stop.load(Ordering::Relaxed) {
        out.exceeded = true;
        out.upper_rad = std::f64::consts::PI;
    }
    Ok(out)
}

struct PieceInput<'a> {
    qa: &'a [f64],
    qb: &'a [f64],
    ta: f64,
    tb: f64,
    ca: Vec<f64>,
    cb: Vec<f64>,
    /// Further known curve samples inside the piece.
    extra: Vec<(f64, Vec<f64>)>,
    breaks: &'a [f64],
    level0: f64,
    eps: f64,
    budget: &'a AtomicUsize,
    /// The decision level (infinite when measuring).
    decide: f64,
    /// Set by any piece that finds a sample beyond `decide`: every piece then stops.
    stop: &'a AtomicBool,
    /// Scale of the parameters, for the width below which an unbounded interval is given up.
    domain_width: f64,
    /// Cancelled: refining stops (the caller then returns `Cancelled`).
    token: &'a crate::sphere::cancel::Cancel,
}

#[derive(Default)]
pub(super) struct Piece {
    pub(super) upper1: f64,
    pub(super) upper2: f64,
    pub(super) lower: f64,
    pub(super) length: f64,
    pub(super) evaluations: usize,
    pub(super) exhausted: bool,
}

/// Segments per parallel job in the closed form for polylines: a segment costs about a
/// microsecond there, so a short line is one job.
const POLYLINE_SEGMENTS_PER_JOB: usize = 4096;

/// Halving stops at intervals this narrow (relative to the parameter's magnitude): below it
/// the parameters themselves round.
const MIN_RELATIVE_WIDTH: f64 = 1e-13;

/// Rounds of sample insertion for the arc-to-curve direction.
const ARC_TO_CURVE_ROUNDS: usize = 24;

/// An interval whose speed bound is still unbounded (a de Boor node's triangle near a half
/// turn) once it is this narrow relative to the domain is given the trivial bound pi instead
/// of being halved on: halving cannot make the bound finite when the control points themselves
/// are near antipodal, and would only spend the whole budget.
const UNBOUNDED_GIVE_UP_WIDTH: f64 = 1e-6;

/// Samples of one piece: parameters, points (flat) and distances to the piece's arc.
struct Samples {
    dim: usize,
    ts: Vec<f64>,
    pts: Vec<f64>,
    fs: Vec<f64>,
}

impl Samples {
    fn point(&self, i: usize) -> &[f64] {
        &self.pts[i * self.dim..(i + 1) * self.dim]
    }
    fn push(&mut self, t: f64, p: &[f64], f: f64) -> usize {
        self.ts.push(t);
        self.pts.extend_from_slice(p);
        self.fs.push(f);
        self.ts.len() - 1
    }
}

/// Takes `want` evaluations from the budget; false when it is spent.
fn take(budget: &AtomicUsize, want: usize) -> bool {
    budget
        .fetch_update(Ordering::Relaxed, Ordering::Relaxed, |b| {
            b.checked_sub(want)
        })
        .is_ok()
}

fn piece_bound(curve: &dyn SphericalCurve, inp: PieceInput<'_>) -> Piece {
    let dim = curve.dim();
    let d = Dynamic(dim);
    let frame = ArcFrame::new(d, inp.qa, inp.qb);
    let mut s = Samples {
        dim,
        ts: Vec::new(),
        pts: Vec::new(),
        fs: Vec::new(),
    };
    let mut lower: f64 = 0.0;
    let mut evaluations = 0;
    let mut exhausted = false;
    let ia = s.push(inp.ta, &inp.ca, frame.distance_dyn(&inp.ca));
    for (t, p) in &inp.extra {
        s.push(*t, p, frame.distance_dyn(p));
    }
    // Interior break points start the subdivision.
    // The breaks are sorted: the piece's own are found by bisection, not by a scan of all of
    // them (which made a check quadratic in the number of knots).
    let first = inp.breaks.partition_point(|&u| u <= inp.ta);
    let last = first + inp.breaks[first..].partition_point(|&u| u < inp.tb);
    let interior: Vec<f64> = inp.breaks[first..last].to_vec();
    let mut chain = vec![ia];
    if !interior.is_empty() {
        evaluations += interior.len();
        exhausted |= !take(inp.budget, interior.len());
        let pts = curve.evaluate_many(&interior);
        for (k, &t) in interior.iter().enumerate() {
            let p = pts.get(k);
            chain.push(s.push(t, p, frame.distance_dyn(p)));
        }
    }
    let ib = s.push(inp.tb, &inp.cb, frame.distance_dyn(&inp.cb));
    chain.push(ib);
    for &f in &s.fs {
        lower = lower.max(f);
    }
    let mut upper1: f64 = s.fs.iter().copied().fold(0.0, f64::max);
    // Curve to arc: breadth-first halving.
    let mut open: Vec<(usize, usize)> = chain.windows(2).map(|w| (w[0], w[1])).collect();
    if inp.tb <= inp.ta {
        open.clear();
    }
    while !open.is_empty() {
        if lower > inp.decide {
            inp.stop.store(true, Ordering::Relaxed);
        }
        if inp.stop.load(Ordering::Relaxed) {
            break;
        }
        exhausted |= inp.token.is_cancelled();
        let level = level_for(&inp, lower);
        let mut split: Vec<(usize, usize)> = Vec::new();
        for &(iu, iv) in &open {
            let (tu, tv) = (s.ts[iu], s.ts[iv]);
            let (pu, pv) = (s.point(iu), s.point(iv));
            let chord = angle_between(pu, pv);
            // Within a knot span the acceleration bound is second order in the width and
            // settles most intervals; the speed bound is the fallback across knots.
            let accel = curve.acceleration_bound(tu, tv);
            let bent = if accel.is_finite() {
                acceleration_deviation(accel, tv - tu, chord) + arc_to_arc_sup(pu, pv, &frame)
            } else {
                f64::INFINITY
            };
            let bound = if bent <= level {
                bent
            } else {
                let speed = curve.speed_bound(tu, tv);
                let length = speed * (tv - tu);
                let lip = 0.5 * (s.fs[iu] + s.fs[iv] + length) + ROUNDING_SLACK_RAD;
                if lip <= level {
                    lip
                } else {
                    lip.min(ellipse_deviation(length, chord) + arc_to_arc_sup(pu, pv, &frame))
                        .min(bent)
                }
            };
            let bound = bound.min(PI);
            let narrow = tv - tu <= MIN_RELATIVE_WIDTH * tu.abs().max(tv.abs()).max(1.0)
                || (bound >= PI && tv - tu <= UNBOUNDED_GIVE_UP_WIDTH * inp.domain_width);
            if bound <= level || narrow || exhausted {
                upper1 = upper1.max(bound);
            } else {
                split.push((iu, iv));
            }
        }
        if split.is_empty() {
            break;
        }
        if !take(inp.budget, split.len()) {
            exhausted = true;
            continue;
        }
        evaluations += split.len();
        let mids: Vec<f64> = split
            .iter()
            .map(|&(iu, iv)| 0.5 * (s.ts[iu] + s.ts[iv]))
            .collect();
        let pts = curve.evaluate_many(&mids);
        open.clear();
        for (k, &(iu, iv)) in split.iter().enumerate() {
            let p = pts.get(k);
            let f = frame.distance_dyn(p);
            lower = lower.max(f);
            let im = s.push(mids[k], p, f);
            open.push((iu, im));
            open.push((im, iv));
        }
    }
    // Arc to curve. The foot of C(t) on the arc moves continuously with t, so it sweeps the
    // stretch between the feet of the piece's two ends: every arc point there is the foot of a
    // curve point, hence within `upper1` of the curve. The rest of the arc (towards its ends) is
    // bounded by its distance to the sample set, refined where high.
    let foot = |i: usize| -> f64 {
        let c = s.point(i);
        let (a, b) = (dot(d, c, &frame.e1), dot(d, c, &frame.e2));
        b.atan2(a).clamp(0.0, frame.theta)
    };
    let (fa, fb) = (foot(ia), foot(ib));
    // (Continuity of the foot needs the curve within pi/2 of the arc, which `upper1` proves.)
    let covered = if upper1 < 1.0 {
        (fa.min(fb), fa.max(fb))
    } else {
        (0.0, 0.0)
    };
    let mut upper2;
    let mut rounds = 0;
    loop {
        if lower > inp.decide {
            inp.stop.store(true, Ordering::Relaxed);
        }
        if inp.stop.load(Ordering::Relaxed) {
            upper2 = PI;
            break;
        }
        exhausted |= inp.token.is_cancelled();
        let level = level_for(&inp, lower);
        let (sup, bad) = arc_to_samples(&frame, &s, level, covered);
        upper2 = sup;
        if covered.1 > covered.0 {
            upper2 = upper2.max(upper1);
        }
        rounds += 1;
        if bad.is_empty() || rounds > ARC_TO_CURVE_ROUNDS || exhausted {
            break;
        }
        let mut order: Vec<usize> = (0..s.ts.len()).collect();
        order.sort_by(|&a, &b| s.ts[a].total_cmp(&s.ts[b]));
        let mut pos = vec![0; s.ts.len()];
        for (k, &i) in order.iter().enumerate() {
            pos[i] = k;
        }
        let mut lefts: Vec<usize> = Vec::new();
        for &i in &bad {
            let k = pos[i];
            if k > 0 {
                lefts.push(k - 1);
            }
            if k + 1 < order.len() {
                lefts.push(k);
            }
        }
        lefts.sort_unstable();
        lefts.dedup();
        let mids: Vec<f64> = lefts
            .iter()
            .map(|&k| (s.ts[order[k]], s.ts[order[k + 1]]))
            .filter(|&(a, b)| b - a > MIN_RELATIVE_WIDTH * a.abs().max(b.abs()).max(1.0))
            .map(|(a, b)| 0.5 * (a + b))
            .collect();
        if mids.is_empty() {
            break;
        }
        if !take(inp.budget, mids.len()) {
            exhausted = true;
            break;
        }
        evaluations += mids.len();
        let pts = curve.evaluate_many(&mids);
        for (k, &t) in mids.iter().enumerate() {
            let p = pts.get(k);
            let f = frame.distance_dyn(p);
            lower = lower.max(f);
            s.push(t, p, f);
        }
    }
    // Length: chords between samples in parameter order.
    let mut order: Vec<usize> = (0..s.ts.len()).collect();
    order.sort_by(|&a, &b| s.ts[a].total_cmp(&s.ts[b]));
    let length = order
        .windows(2)
        .map(|w| angle_between(s.point(w[0]), s.point(w[1])))
        .sum();
    Piece {
        upper1,
        upper2,
        lower,
        length,
        evaluations,
        exhausted,
    }
}

/// The level below which an interval's bound is accepted: the best lower bound plus the
/// precision when measuring, or the decision level when that is higher.
fn level_for(inp: &PieceInput<'_>, lower: f64) -> f64 {
    acceptance_level(inp.level0, inp.eps, inp.decide, lower)
}

/// [`level_for`] from its parts: the largest vertex error `level0`, the precision `eps`, the
/// decision level `decide` (infinite when measuring) and the best lower bound so far.
pub(super) fn acceptance_level(level0: f64, eps: f64, decide: f64, lower: f64) -> f64 {
    let measured = level0.max(lower) + eps;
    if decide.is_finite() {
        measured.max(decide)
    } else {
        measured
    }
}

/// The parts of `[l, r]` outside the open interval `skip` (all of it when `skip` is empty).
fn allowed_parts(l: f64, r: f64, skip: (f64, f64)) -> Vec<(f64, f64)> {
    if l > r {
        return Vec::new();
    }
    if skip.1 <= skip.0 {
        return vec![(l, r)];
    }
    let mut out = Vec::with_capacity(2);
    if l <= skip.0 {
        out.push((l, r.min(skip.0)));
    }
    if r >= skip.1 {
        out.push((l.max(skip.1), r));
    }
    out
}

/// A sample seen from the arc's frame: along-track angle `phi`, and its distance to the arc's
/// plane as `perp` (sine) and `r` (the in-plane length, cosine).
#[derive(Clone, Copy)]
struct Seen {
    phi: f64,
    r: f64,
    perp: f64,
    index: usize,
}

/// Exact distance from the arc point at along-track angle `s` to the sample `k`:
/// chord^2 = (1 - r)^2 + 4 r sin^2((s - phi)/2) + perp^2, with 1 - r = perp^2 / (1 + r).
#[inline]
fn dist_from_arc_point(k: &Seen, s: f64) -> f64 {
    let one_minus_r = k.perp * k.perp / (1.0 + k.r);
    let h = ((s - k.phi) / 2.0).sin();
    let chord2 = one_minus_r * one_minus_r + 4.0 * k.r * h * h + k.perp * k.perp;
    2.0 * (0.5 * chord2.sqrt()).min(1.0).asin()
}

/// The largest distance from a point of the arc to the nearest sample (an upper bound of the
/// arc-to-curve distance, since the samples are curve points), and the samples next to the
/// places where it exceeds `level`.
///
/// Samples sorted by along-track angle cover the arc: between two neighbours k, k' the
/// distance to k grows and the distance to k' shrinks, so the larger of the two at any point
/// s between them bounds the smaller of the two everywhere between; s is chosen where they
/// cross. Beyond the first (last) sample the distance to it is largest at the arc's end.
///
/// Only the arc outside `skip` (an interval of along-track angles bounded otherwise) counts.
fn arc_to_samples(
    frame: &ArcFrame,
    s: &Samples,
    level: f64,
    skip: (f64, f64),
) -> (f64, Vec<usize>) {
    let mut bad = Vec::new();
    let dim = s.dim;
    let d = Dynamic(dim);
    if frame.degenerate() {
        let (mut best, mut at) = (f64::INFINITY, 0);
        for i in 0..s.ts.len() {
            let e = angle_between(&frame.e1, s.point(i));
            if e < best {
                best = e;
                at = i;
            }
        }
        if best > level {
            bad.push(at);
        }
        return (best + ROUNDING_SLACK_RAD, bad);
    }
    let mut seen: Vec<Seen> = Vec::with_capacity(s.ts.len());
    seen.extend((0..s.ts.len()).map(|i| {
        let c = s.point(i);
        let a = dot(d, c, &frame.e1);
        let b = dot(d, c, &frame.e2);
        let mut perp2 = 0.0;
        for k in 0..dim {
            let r = c[k] - a * frame.e1[k] - b * frame.e2[k];
            perp2 += r * r;
        }
        Seen {
            phi: b.atan2(a),
            r: a.hypot(b),
            perp: perp2.sqrt(),
            index: i,
        }
    }));
    seen.sort_by(|a, b| a.phi.total_cmp(&b.phi));
    let theta = frame.theta;
    let mut sup: f64 = 0.0;
    let note = |v: f64, ks: &[usize], sup: &mut f64, bad: &mut Vec<usize>| {
        *sup = sup.max(v);
        if v > level {
            bad.extend_from_slice(ks);
        }
    };
    // Before the first sample the distance to it shrinks towards it: largest at the left end
    // of each allowed part; after the last, at the right end.
    let first = seen[0];
    for (l, _) in allowed_parts(0.0, first.phi.min(theta), skip) {
        note(
            dist_from_arc_point(&first, l),
            &[first.index],
            &mut sup,
            &mut bad,
        );
    }
    for w in seen.windows(2) {
        let (k, k2) = (w[0], w[1]);
        let (l, r) = (k.phi.max(0.0), k2.phi.min(theta));
        if l >= r {
            continue;
        }
        let g = k2.phi - k.phi;
        let u = (k.r - k2.r * g.cos()).atan2(k2.r * g.sin());
        // The parts of [l, r] outside `skip`; on each, any point bounds the smaller distance.
        // On a part, the nearer of the two is farthest at the crossing, or at the part's end
        // nearest to it when the crossing lies outside the part (the distance to k grows and
        // that to k2 shrinks along the part): there it is the smaller of the two, not the
        // larger (a sliver of the arc next to k2 is not as far as k is).
        for (l, r) in allowed_parts(l, r, skip) {
            let crossing = k.phi + u;
            let at = crossing.clamp(l, r);
            let (dk, dk2) = (dist_from_arc_point(&k, at), dist_from_arc_point(&k2, at));
            let v = if at == crossing {
                dk.max(dk2)
            } else {
                dk.min(dk2)
            };
            note(v, &[k.index, k2.index], &mut sup, &mut bad);
        }
    }
    let last = seen[seen.len() - 1];
    for (_, r) in allowed_parts(last.phi.max(0.0), theta, skip) {
        note(
            dist_from_arc_point(&last, r),
            &[last.index],
            &mut sup,
            &mut bad,
        );
    }
    bad.sort_unstable();
    bad.dedup();
    (sup + ROUNDING_SLACK_RAD, bad)
}

#[cfg(test)]
mod tests;
