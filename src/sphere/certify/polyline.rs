//! The two-way distance ([`super::two_way`]) of a curve that is a chain of great-circle arcs
//! (a degree-1 B-spline), in closed form.
//!
//! Between two of its vertices such a curve is one great-circle arc, so the piece matched to a
//! segment of the line is a short chain of arcs: its ends, the extra sample where the first
//! point's parameter lies inside the domain, and the vertices between. The curve-to-arc part
//! of the Hausdorff distance is then the largest [`arc_to_arc_sup`] over the chain's arcs,
//! with no speed bound and no subdivision; the arc-to-curve part is the same bound over the
//! chain's vertices as samples that the general method starts from. Where either is not
//! tight (the bound above its attained distances by more than the precision, or an arc stretch
//! far from every vertex), the segment goes to the general method instead.
//!
//! Polylines are what the tolerance fitter returns for borders, coastlines and GPS tracks, and
//! the general method (evaluations through the curve trait, speed bounds, sample vectors per
//! segment) was a third of the fitting time of a coastline dataset.

use super::bounds::arc_to_arc_sup_attained;
use super::two_way::{arc_to_samples_into, Piece, Samples, Seen};
use crate::sphere::compress::simplify::ArcFrame;
use crate::sphere::geometry::point::{angle_between, dot, Dynamic, PointSet};

/// Reused between the segments of one job: the chain (as samples of the piece) and the
/// arc-to-samples working space.
pub(super) struct Scratch {
    samples: Samples,
    seen: Vec<Seen>,
    bad: Vec<usize>,
}

impl Scratch {
    pub(super) fn new(dim: usize) -> Scratch {
        Scratch {
            samples: Samples {
                dim,
                ts: Vec::new(),
                pts: Vec::new(),
                fs: Vec::new(),
            },
            seen: Vec::new(),
            bad: Vec::new(),
        }
    }
}

/// One segment's piece, `qa`–`qb` against the curve over `[ta, tb]`.
pub(super) struct Segment<'a> {
    pub(super) qa: &'a [f64],
    pub(super) qb: &'a [f64],
    pub(super) ta: f64,
    pub(super) tb: f64,
    /// C(ta) and C(tb).
    pub(super) ca: &'a [f64],
    pub(super) cb: &'a [f64],
    /// A further curve sample inside `(ta, tb)` (the first point's own, when its parameter is
    /// past the domain's start).
    pub(super) extra: Option<(f64, &'a [f64])>,
}

/// The level an attained distance must stay within for a bound to count as tight, and the
/// decision level: see `level_for` in [`super::two_way`].
pub(super) struct Levels {
    /// The largest vertex error (every segment's bound is at least this anyway).
    pub(super) level0: f64,
    /// Precision asked for.
    pub(super) eps: f64,
    /// Decision level (infinite when measuring).
    pub(super) decide: f64,
}

impl Levels {
    fn level(&self, lower: f64) -> f64 {
        let measured = self.level0.max(lower) + self.eps;
        if self.decide.is_finite() {
            measured.max(self.decide)
        } else {
            measured
        }
    }
}

/// The bounds of one segment's piece of the polyline curve (`params`, `vertices`: its vertex
/// parameters and vertices), or `None` when the closed form is not tight there.
pub(super) fn piece(
    params: &[f64],
    vertices: &PointSet,
    seg: &Segment<'_>,
    levels: &Levels,
    sc: &mut Scratch,
) -> Option<Piece> {
    let dim = vertices.dim();
    let frame = ArcFrame::new(Dynamic(dim), seg.qa, seg.qb);
    let s = &mut sc.samples;
    s.ts.clear();
    s.pts.clear();
    s.fs.clear();
    // The chain in parameter order: C(ta), the vertices strictly inside (ta, tb) with the
    // extra sample among them, C(tb).
    s.push(seg.ta, seg.ca, frame.distance_dyn(seg.ca));
    let first = params.partition_point(|&u| u <= seg.ta);
    let last = first + params[first..].partition_point(|&u| u < seg.tb);
    let mut extra = seg.extra.filter(|(t, _)| *t > seg.ta && *t < seg.tb);
    for i in first..last {
        if let Some((t, p)) = extra.filter(|(t, _)| *t <= params[i]) {
            s.push(t, p, frame.distance_dyn(p));
            extra = None;
        }
        let v = vertices.get(i);
        s.push(params[i], v, frame.distance_dyn(v));
    }
    if let Some((t, p)) = extra {
        s.push(t, p, frame.distance_dyn(p));
    }
    s.push(seg.tb, seg.cb, frame.distance_dyn(seg.cb));
    let m = s.ts.len();
    let mut lower = s.fs.iter().copied().fold(0.0, f64::max);
    let mut upper1 = lower;
    let mut length = 0.0;
    for i in 1..m {
        let (pu, pv) = (s.point(i - 1), s.point(i));
        let (bound, attained) = arc_to_arc_sup_attained(pu, pv, &frame);
        upper1 = upper1.max(bound);
        lower = lower.max(attained);
        length += angle_between(pu, pv);
    }
    let level = levels.level(lower);
    if upper1 > level && lower <= levels.decide {
        // Not tight: the general method subdivides.
        return None;
    }
    // Arc to curve, as in the general method: the stretch of the arc between the feet of the
    // piece's ends is within `upper1` of the curve; the rest is bounded by the distance to
    // the chain's vertices.
    let foot = |p: &[f64]| -> f64 {
        let d = Dynamic(dim);
        let (a, b) = (dot(d, p, &frame.e1), dot(d, p, &frame.e2));
        b.atan2(a).clamp(0.0, frame.theta)
    };
    let (fa, fb) = (foot(seg.ca), foot(seg.cb));
    let covered = if upper1 < 1.0 {
        (fa.min(fb), fa.max(fb))
    } else {
        (0.0, 0.0)
    };
    let mut upper2 = arc_to_samples_into(&frame, s, level, covered, &mut sc.seen, &mut sc.bad);
    if !sc.bad.is_empty() && lower <= levels.decide {
        return None;
    }
    if covered.1 > covered.0 {
        upper2 = upper2.max(upper1);
    }
    Some(Piece {
        upper1,
        upper2,
        lower,
        length,
        evaluations: m,
        exhausted: false,
    })
}
