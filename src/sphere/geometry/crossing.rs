//! Crossings of great-circle segments on S^2: whether two short arcs of great circles cross,
//! and the crossings between (and within) polylines, found by descending boxes of runs of
//! segments.
//!
//! Two segments `a-b` and `c-d` (each shorter than a half turn) cross when `c` and `d` lie on
//! opposite sides of the great circle through `a`, `b` (the signs of `(a × b) · c` and
//! `(a × b) · d` differ, strictly), `a` and `b` on opposite sides of the one through `c`, `d`,
//! and the two segments are on the same side of the sphere (`(a + b) · (c + d) > 0`), so the
//! crossing is the one near them, not its antipode. Touching (an end on the other segment, a
//! shared end) is not crossing.

/// `a × b`.
fn cross(a: &[f64; 3], b: &[f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn dot(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// True when the great-circle segments `a-b` and `c-d` cross (see the module docs).
pub fn segments_cross(a: &[f64; 3], b: &[f64; 3], c: &[f64; 3], d: &[f64; 3]) -> bool {
    let n1 = cross(a, b);
    let (sc, sd) = (dot(&n1, c), dot(&n1, d));
    if !((sc > 0.0 && sd < 0.0) || (sc < 0.0 && sd > 0.0)) {
        return false;
    }
    let n2 = cross(c, d);
    let (sa, sb) = (dot(&n2, a), dot(&n2, b));
    if !((sa > 0.0 && sb < 0.0) || (sa < 0.0 && sb > 0.0)) {
        return false;
    }
    let m1 = [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
    let m2 = [c[0] + d[0], c[1] + d[1], c[2] + d[2]];
    dot(&m1, &m2) > 0.0
}

/// An axis-aligned box around points of R^3 (a great-circle segment shorter than a quarter
/// turn bulges out of its chord's box by at most its sagitta, added as a margin).
#[derive(Clone, Copy, Debug)]
struct Box3 {
    lo: [f64; 3],
    hi: [f64; 3],
}

impl Box3 {
    fn of(points: &[[f64; 3]]) -> Box3 {
        let mut b = Box3 {
            lo: [f64::INFINITY; 3],
            hi: [f64::NEG_INFINITY; 3],
        };
        for p in points {
            for k in 0..3 {
                b.lo[k] = b.lo[k].min(p[k]);
                b.hi[k] = b.hi[k].max(p[k]);
            }
        }
        b
    }

    fn grown(mut self, m: f64) -> Box3 {
        for k in 0..3 {
            self.lo[k] -= m;
            self.hi[k] += m;
        }
        self
    }

    fn union(self, o: &Box3) -> Box3 {
        let mut b = self;
        for k in 0..3 {
            b.lo[k] = b.lo[k].min(o.lo[k]);
            b.hi[k] = b.hi[k].max(o.hi[k]);
        }
        b
    }

    fn meets(&self, o: &Box3) -> bool {
        (0..3).all(|k| self.lo[k] <= o.hi[k] && o.lo[k] <= self.hi[k])
    }
}

/// Margin for a segment's box: its sagitta, 1 − cos(θ/2) ≤ θ²/8 with θ ≤ the chord · π/2.
fn sagitta(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    let c2 = (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2);
    0.31 * c2 + 1e-15
}

/// Boxes of a polyline's segments and of runs of them: level 0 is segment `i`'s box, level
/// `l` the union of level `l - 1`'s boxes `2i` and `2i + 1` (runs of `2^l` consecutive
/// segments). A polyline stays near itself, so the boxes of long runs are tight and two
/// polylines are compared run against run, splitting only runs whose boxes meet.
///
/// Built once per polyline by a caller that compares one polyline with many
/// ([`polylines_meet_boxed`]): building them was three quarters of the crossing checks of a
/// coverage fit (world-atlas countries-10m at 1 km, callgrind), each pair building both.
/// Only runs of 8 segments and longer are kept; shorter ones are boxed again from
/// their points when a descent reaches them. Keeping every level took 96 bytes a segment,
/// and a coverage's checks of its input and its fit held about 90 MB of them on the 10m
/// countries (a third of the run's peak memory, each page faulted in: docs/speed.md, "tenth
/// session"); this keeps 12.
pub struct RunBoxes {
    /// `stored[k]`: the boxes of level [`STORED_FROM`] + k.
    stored: Vec<Vec<Box3>>,
    /// Segments of the polyline.
    segments: usize,
    /// The margin each segment's box is grown by.
    margin: fn(&[f64; 3], &[f64; 3]) -> f64,
}

/// The lowest level of [`RunBoxes`] kept: runs of [`STORED_RUN`] segments.
const STORED_FROM: usize = 3;

/// Segments in a run of the lowest level kept.
const STORED_RUN: usize = 1 << STORED_FROM;

/// How two segments are judged: the margin a segment bulges out of its chord's box, and
/// whether two segments (sharing no end) meet. Great-circle arcs on S^2 are
/// [`GREAT_CIRCLE`]; a caller with another geometry of the same points (planar longitude and
/// latitude as a GIS draws them, in the Earth layer) brings its own.
#[derive(Clone, Copy, Debug)]
pub struct SegmentTest {
    /// The margin to grow the box of the segment between two points by.
    pub margin: fn(&[f64; 3], &[f64; 3]) -> f64,
    /// Whether segments `a-b` and `c-d` meet.
    pub meets: SegmentPredicate,
}

/// Whether segments `a-b` and `c-d` meet.
pub type SegmentPredicate = fn(&[f64; 3], &[f64; 3], &[f64; 3], &[f64; 3]) -> bool;

/// Great-circle segments of unit vectors, crossing as [`segments_cross`] says.
pub const GREAT_CIRCLE: SegmentTest = SegmentTest {
    margin: sagitta,
    meets: segments_cross,
};

impl RunBoxes {
    /// The boxes of `points`' segments, each grown by `margin` (a [`SegmentTest`]'s), and of
    /// their runs.
    pub fn of(points: &[[f64; 3]], margin: fn(&[f64; 3], &[f64; 3]) -> f64) -> RunBoxes {
        let segments = points.len().saturating_sub(1);
        let lowest: Vec<Box3> = (0..segments)
            .step_by(STORED_RUN)
            .map(|s| segment_boxes(points, margin, s, (s + STORED_RUN).min(segments) - 1))
            .collect();
        let mut stored = vec![lowest];
        while stored.last().is_some_and(|l| l.len() > 1) {
            let below = stored.last().expect("a level");
            let up = below
                .chunks(2)
                .map(|c| c.iter().skip(1).fold(c[0], |b, o| b.union(o)))
                .collect();
            stored.push(up);
        }
        RunBoxes {
            stored,
            segments,
            margin,
        }
    }

    fn top(&self) -> usize {
        STORED_FROM + self.stored.len() - 1
    }

    /// The segments of run `i` at level `l`: `i·2^l ..` (at most `2^l` of them).
    fn first(l: usize, i: usize) -> usize {
        i << l
    }

    fn last(&self, l: usize, i: usize) -> usize {
        (((i + 1) << l) - 1).min(self.segments - 1)
    }

    /// Runs at level `l`.
    fn runs(&self, l: usize) -> usize {
        self.segments.div_ceil(1 << l)
    }

    /// The box of run `i` at level `l` (at least [`STORED_FROM`]).
    fn run_box(&self, l: usize, i: usize) -> Box3 {
        self.stored[l - STORED_FROM][i]
    }
}

/// The union of the boxes of segments `first ..= last` of `points`, each grown by `margin`.
fn segment_boxes(
    points: &[[f64; 3]],
    margin: fn(&[f64; 3], &[f64; 3]) -> f64,
    first: usize,
    last: usize,
) -> Box3 {
    (first..=last)
        .map(|i| {
            let (a, b) = (&points[i], &points[i + 1]);
            Box3::of(&[*a, *b]).grown(margin(a, b))
        })
        .reduce(|u, b| u.union(&b))
        .expect("a run holds a segment")
}

/// Whether two polylines (unit vectors) cross anywhere; with `same`, whether one polyline
/// crosses itself (neighbouring segments, which share a vertex, never count).
///
/// Every pair of segments whose boxes meet is tested with [`segments_cross`]; pairs are found
/// by descending the two polylines' run boxes (`RunBoxes`) together, so a long border is not compared
/// segment by segment with every other (that quadratic scan was 57 % of a coverage fit of the
/// 10m countries).
pub fn polylines_cross(p: &[[f64; 3]], q: &[[f64; 3]], same: bool) -> bool {
    polylines_meet(p, q, same, GREAT_CIRCLE)
}

/// As [`polylines_cross`], with segments judged by `test`.
pub fn polylines_meet(p: &[[f64; 3]], q: &[[f64; 3]], same: bool, test: SegmentTest) -> bool {
    if p.len() < 2 || q.len() < 2 {
        return false;
    }
    let bp = RunBoxes::of(p, test.margin);
    let owned;
    let bq = if same {
        &bp
    } else {
        owned = RunBoxes::of(q, test.margin);
        &owned
    };
    polylines_meet_boxed((p, &bp), (q, bq), same, test)
}

/// As [`polylines_meet`], with each polyline's [`RunBoxes`] built already (by
/// [`RunBoxes::of`] with `test.margin`).
pub fn polylines_meet_boxed(
    p: (&[[f64; 3]], &RunBoxes),
    q: (&[[f64; 3]], &RunBoxes),
    same: bool,
    test: SegmentTest,
) -> bool {
    visit_meetings(p, q, same, test, &mut |_, _| true)
}

/// Every pair `(i, j)` of a segment `i` (from `p[i]` to `p[i + 1]`) and a segment `j` of `q`
/// that meet, as [`polylines_meet_boxed`] judges them (with `same`, each pair once, `i < j`):
/// where two lines meet, for a caller that mends them there.
pub fn meeting_segments_boxed(
    p: (&[[f64; 3]], &RunBoxes),
    q: (&[[f64; 3]], &RunBoxes),
    same: bool,
    test: SegmentTest,
) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    visit_meetings(p, q, same, test, &mut |i, j| {
        out.push((i, j));
        false
    });
    out
}

/// Visits the meeting pairs of segments of `p` and `q` in order until `found` returns true;
/// whether it did.
fn visit_meetings(
    (p, bp): (&[[f64; 3]], &RunBoxes),
    (q, bq): (&[[f64; 3]], &RunBoxes),
    same: bool,
    test: SegmentTest,
    found: &mut dyn FnMut(usize, usize) -> bool,
) -> bool {
    if p.len() < 2 || q.len() < 2 {
        return false;
    }
    let (tp, tq) = (bp.top(), bq.top());
    runs_cross(Pair { p, q, same, test }, bp, bq, (tp, 0), (tq, 0), found)
}

/// The two polylines compared, whether they are one, and how segments are judged.
#[derive(Clone, Copy)]
struct Pair<'a> {
    p: &'a [[f64; 3]],
    q: &'a [[f64; 3]],
    same: bool,
    test: SegmentTest,
}

/// Visits the pairs `(i, j)` of a segment `i` of run `(lp, ip)` of `p` and a segment `j` of
/// run `(lq, iq)` of `q` that meet, in order, until `found` returns true; whether it did.
fn runs_cross(
    pair: Pair<'_>,
    bp: &RunBoxes,
    bq: &RunBoxes,
    (lp, ip): (usize, usize),
    (lq, iq): (usize, usize),
    found: &mut dyn FnMut(usize, usize) -> bool,
) -> bool {
    let Pair { p, q, same, test } = pair;
    // Within one polyline only pairs j >= i + 2 count.
    if same && bq.last(lq, iq) < RunBoxes::first(lp, ip) + 2 {
        return false;
    }
    if !bp.run_box(lp, ip).meets(&bq.run_box(lq, iq)) {
        return false;
    }
    if lp == STORED_FROM && lq == STORED_FROM {
        // Two runs of the lowest level kept: their segments' boxes, then each pair of
        // segments whose boxes meet.
        let (i0, i1) = (RunBoxes::first(lp, ip), bp.last(lp, ip));
        let (j0, j1) = (RunBoxes::first(lq, iq), bq.last(lq, iq));
        let boxes = |points: &[[f64; 3]], margin: fn(&[f64; 3], &[f64; 3]) -> f64, k0, k1| {
            let mut b = [None; STORED_RUN];
            for k in k0..=k1 {
                b[k - k0] = Some(segment_boxes(points, margin, k, k));
            }
            b
        };
        let sp = boxes(p, bp.margin, i0, i1);
        let sq = if same && ip == iq {
            sp
        } else {
            boxes(q, bq.margin, j0, j1)
        };
        for i in i0..=i1 {
            for j in j0..=j1 {
                if same && j < i + 2 {
                    continue;
                }
                let (Some(u), Some(v)) = (sp[i - i0], sq[j - j0]) else {
                    continue;
                };
                if !u.meets(&v) {
                    continue;
                }
                let (a, b, c, d) = (&p[i], &p[i + 1], &q[j], &q[j + 1]);
                // Segments that share an end touch there (ends at a junction, a ring's seam,
                // a segment and the next). Within one line any other shared end is the line
                // coming back to a position it passed, an out-and-back spike or a pinch,
                // which GIS tools refuse: the 50m United States at 20 km per feature went
                // into Tomales Bay and back to the same position, unseen.
                let meets = if a == c || a == d || b == c || b == d {
                    let seam = i == 0 && j + 2 == q.len() && q[0] == q[q.len() - 1];
                    same && j != i + 1 && !seam
                } else {
                    (test.meets)(a, b, c, d)
                };
                if meets && found(i, j) {
                    return true;
                }
            }
        }
        return false;
    }
    // Split the larger run (the one higher up); its halves, when there.
    if lp >= lq {
        (0..2)
            .map(|h| 2 * ip + h)
            .filter(|&i| i < bp.runs(lp - 1))
            .any(|i| runs_cross(pair, bp, bq, (lp - 1, i), (lq, iq), found))
    } else {
        (0..2)
            .map(|h| 2 * iq + h)
            .filter(|&j| j < bq.runs(lq - 1))
            .any(|j| runs_cross(pair, bp, bq, (lp, ip), (lq - 1, j), found))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn u(lon: f64, lat: f64) -> [f64; 3] {
        let (lo, la) = (lon.to_radians(), lat.to_radians());
        [la.cos() * lo.cos(), la.cos() * lo.sin(), la.sin()]
    }

    #[test]
    fn crossing_touching_and_antipodal_segments() {
        assert!(segments_cross(
            &u(0.0, -1.0),
            &u(0.0, 1.0),
            &u(-1.0, 0.0),
            &u(1.0, 0.0)
        ));
        // Touching at an end, or sharing one, is not crossing.
        assert!(!segments_cross(
            &u(0.0, -1.0),
            &u(0.0, 1.0),
            &u(0.0, 0.0),
            &u(1.0, 0.0)
        ));
        assert!(!segments_cross(
            &u(0.0, 0.0),
            &u(0.0, 1.0),
            &u(0.0, 0.0),
            &u(1.0, 0.0)
        ));
        // The antipodal copy of a crossing segment does not cross.
        assert!(!segments_cross(
            &u(0.0, -1.0),
            &u(0.0, 1.0),
            &u(179.0, 0.0),
            &u(-179.0, 0.0)
        ));
        // Disjoint.
        assert!(!segments_cross(
            &u(0.0, 0.0),
            &u(1.0, 0.0),
            &u(0.0, 1.0),
            &u(1.0, 1.0)
        ));
        // Across the antimeridian, where lon/lat would wrap.
        assert!(segments_cross(
            &u(179.5, 0.0),
            &u(-179.5, 0.0),
            &u(180.0, -1.0),
            &u(180.0, 1.0)
        ));
    }

    /// Every pair of segments tested, as the run boxes must agree with.
    fn brute_force(p: &[[f64; 3]], q: &[[f64; 3]], same: bool) -> bool {
        !every_crossing(p, q, same).is_empty()
    }

    /// Every crossing pair of segments, found by testing each pair, in order.
    fn every_crossing(p: &[[f64; 3]], q: &[[f64; 3]], same: bool) -> Vec<(usize, usize)> {
        let mut out = Vec::new();
        for i in 0..p.len().saturating_sub(1) {
            let start = if same { i + 2 } else { 0 };
            for j in start..q.len().saturating_sub(1) {
                let (a, b, c, d) = (&p[i], &p[i + 1], &q[j], &q[j + 1]);
                // Within one line, a shared end other than at a ring's seam is a revisit.
                let seam = i == 0 && j + 2 == q.len() && q[0] == q[q.len() - 1];
                let meets = if a == c || a == d || b == c || b == d {
                    same && !seam
                } else {
                    segments_cross(a, b, c, d)
                };
                if meets {
                    out.push((i, j));
                }
            }
        }
        out
    }

    proptest::proptest! {
        /// Random walks (crossing themselves and each other or not, of any length, sharing
        /// vertices sometimes): the run boxes find a crossing exactly when one exists.
        #[test]
        fn run_boxes_agree_with_every_pair(
            steps_p in proptest::collection::vec((-1.0f64..1.0, -1.0f64..1.0), 0..60),
            steps_q in proptest::collection::vec((-1.0f64..1.0, -1.0f64..1.0), 0..60),
            scale in 0.01f64..3.0,
            share in proptest::bool::ANY,
        ) {
            let walk = |steps: &[(f64, f64)], lon0: f64| {
                let (mut lon, mut lat) = (lon0, 0.0);
                steps
                    .iter()
                    .map(|&(a, b)| {
                        lon += a * scale;
                        lat = (lat + b * scale).clamp(-80.0, 80.0);
                        u(lon, lat)
                    })
                    .collect::<Vec<_>>()
            };
            let p = walk(&steps_p, 0.0);
            let mut q = walk(&steps_q, 0.3);
            if share && !p.is_empty() && !q.is_empty() {
                q[0] = p[p.len() / 2];
            }
            proptest::prop_assert_eq!(polylines_cross(&p, &q, false), brute_force(&p, &q, false));
            let (bp, bq) = (RunBoxes::of(&p, sagitta), RunBoxes::of(&q, sagitta));
            let mut found = meeting_segments_boxed((&p, &bp), (&q, &bq), false, GREAT_CIRCLE);
            found.sort_unstable();
            proptest::prop_assert_eq!(found, every_crossing(&p, &q, false));
            let mut found = meeting_segments_boxed((&p, &bp), (&p, &bp), true, GREAT_CIRCLE);
            found.sort_unstable();
            proptest::prop_assert_eq!(found, every_crossing(&p, &p, true));
            proptest::prop_assert_eq!(polylines_cross(&p, &p, true), brute_force(&p, &p, true));
            proptest::prop_assert_eq!(polylines_cross(&q, &q, true), brute_force(&q, &q, true));
        }
    }

    #[test]
    fn polylines_and_self_crossings() {
        let zig: Vec<[f64; 3]> = [(0.0, 0.0), (1.0, 0.0), (0.5, 1.0), (0.5, -1.0)]
            .iter()
            .map(|&(a, b)| u(a, b))
            .collect();
        assert!(polylines_cross(&zig, &zig, true));
        let straight: Vec<[f64; 3]> = (0..10).map(|i| u(i as f64 * 0.1, 0.0)).collect();
        assert!(!polylines_cross(&straight, &straight, true));
        let other: Vec<[f64; 3]> = (0..10).map(|i| u(0.55, -0.45 + i as f64 * 0.1)).collect();
        assert!(polylines_cross(&straight, &other, false));
        let apart: Vec<[f64; 3]> = (0..10).map(|i| u(5.0, -0.5 + i as f64 * 0.1)).collect();
        assert!(!polylines_cross(&straight, &apart, false));
    }

    #[test]
    fn a_line_back_at_a_position_it_passed_meets_itself() {
        let line = |pts: &[(f64, f64)]| pts.iter().map(|&(a, b)| u(a, b)).collect::<Vec<_>>();
        // A closed ring: its first and last segments share the seam, its neighbours their
        // ends; none of that is a meeting.
        let square = line(&[(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0), (0.0, 0.0)]);
        assert!(!polylines_cross(&square, &square, true));
        // Out into a bay and back to the same position (0.5, 1): every pair of segments
        // there that are not neighbours.
        let spike = line(&[
            (0.0, 0.0),
            (1.0, 0.0),
            (1.0, 1.0),
            (0.5, 1.0),
            (0.5, 2.0),
            (0.5, 1.0),
            (0.0, 1.0),
            (0.0, 0.0),
        ]);
        let b = RunBoxes::of(&spike, GREAT_CIRCLE.margin);
        assert_eq!(
            meeting_segments_boxed((&spike, &b), (&spike, &b), true, GREAT_CIRCLE),
            vec![(2, 4), (2, 5), (3, 5)]
        );
        // Two lines sharing an end (arcs at a junction) do not meet there.
        let (p, q) = (
            line(&[(0.0, 0.0), (1.0, 0.0)]),
            line(&[(1.0, 0.0), (2.0, 1.0)]),
        );
        assert!(!polylines_cross(&p, &q, false));
    }
}
