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

use crate::sphere::certify::bounds::arc_to_arc_known;
use crate::sphere::certify::two_way::Piece;
use crate::sphere::geometry::arc::ArcFrame;
use crate::sphere::geometry::point::{angle, Dim, PointSet};

/// One segment's piece, `qa`–`qb` against the curve over `[ta, tb]`.
pub(super) struct Segment<'a> {
    pub(super) qa: &'a [f64],
    pub(super) qb: &'a [f64],
    pub(super) ta: f64,
    pub(super) tb: f64,
    /// C(ta) and C(tb).
    pub(super) ca: &'a [f64],
    pub(super) cb: &'a [f64],
    /// d(qa, C(ta)) and d(qb, C(tb)) when known (the vertex errors), else `None`.
    pub(super) ea: Option<f64>,
    pub(super) eb: Option<f64>,
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
        super::two_way::acceptance_level(self.level0, self.eps, self.decide, lower)
    }
}

/// The bounds of one segment's piece of the polyline curve (`params`, `vertices`: its vertex
/// parameters and vertices), or `None` when the closed form is not tight there.
pub(super) fn piece<'a>(
    params: &[f64],
    vertices: &'a PointSet,
    seg: &Segment<'a>,
    levels: &Levels,
) -> Option<Piece> {
    crate::with_dim!(vertices.dim(), |d| piece_in(
        d, params, vertices, seg, levels
    ))
}

fn piece_in<'a, D: Dim>(
    d: D,
    params: &[f64],
    vertices: &'a PointSet,
    seg: &Segment<'a>,
    levels: &Levels,
) -> Option<Piece> {
    let frame = ArcFrame::new(d, seg.qa, seg.qb);
    if frame.is_antipodal() {
        return None;
    }
    // Curve to arc: the chain in parameter order, C(ta), the vertices strictly inside
    // (ta, tb) with the extra sample among them, C(tb), one arc at a time.
    let (mut lower, mut upper1, mut length) = (0.0f64, 0.0f64, 0.0f64);
    let mut prev: Option<(&[f64], f64)> = None;
    let mut visit = |p: &'a [f64]| {
        let f = frame.distance(d, p);
        lower = lower.max(f);
        upper1 = upper1.max(f);
        if let Some((q, fq)) = prev {
            let c = angle(d, q, p);
            let (bound, attained) = arc_to_arc_known(d, q, p, c, (fq, f), &frame);
            upper1 = upper1.max(bound);
            lower = lower.max(attained);
            length += c;
        }
        prev = Some((p, f));
    };
    visit(seg.ca);
    let first = params.partition_point(|&u| u <= seg.ta);
    let last = first + params[first..].partition_point(|&u| u < seg.tb);
    let mut extra = seg.extra.filter(|(t, _)| *t > seg.ta && *t < seg.tb);
    for i in first..last {
        if let Some((_, p)) = extra.filter(|(t, _)| *t <= params[i]) {
            visit(p);
            extra = None;
        }
        visit(vertices.get(i));
    }
    if let Some((_, p)) = extra {
        visit(p);
    }
    visit(seg.cb);
    let chain = last - first + 2 + usize::from(seg.extra.is_some());
    if (upper1 > levels.level(lower) || upper1 >= 1.0) && lower <= levels.decide {
        // Not tight (or too far for the argument below): the general method subdivides.
        return None;
    }
    // Arc to curve. As C runs over the piece, its foot on the arc moves continuously from the
    // foot of C(ta) to that of C(tb) (the piece is within 1 rad of the arc), so every arc
    // point between them is the foot of a curve point: within `upper1`. The distance from a
    // point to the arc's points grows away from its foot, so on the arc before the first
    // foot (after the last) the distance to C(ta) (to C(tb)) is largest at the arc's end.
    let ea = seg.ea.unwrap_or_else(|| angle(d, seg.qa, seg.ca));
    let eb = seg.eb.unwrap_or_else(|| angle(d, seg.qb, seg.cb));
    Some(Piece {
        upper1,
        upper2: upper1.max(ea).max(eb),
        lower,
        length,
        evaluations: chain,
        exhausted: false,
    })
}
