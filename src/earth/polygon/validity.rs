//! Valid polygons as GIS tools read them: fitted rings must not meet where the input's did not.
//!
//! A fitted ring stays within the tolerance of its input, but two rings closer than twice the
//! tolerance (an island off a coast, the two shores of a spit, a hole near its shell) can meet
//! once fitted, and a polygon whose rings meet is invalid (OGC simple features; GDAL's
//! `IsValid`, shapely and geo refuse it). Two judges are asked, because two readers matter:
//! - on the sphere, the great-circle edges of the fitted rings as spherefit means them
//!   ([`crate::sphere::geometry::crossing`]);
//! - in the plane, the edges as a GIS draws and validates them: straight in longitude and
//!   latitude, between positions *as written* (rounded to `precision` decimals), where touching
//!   counts. Rounding alone can make a ring touch itself: a 10m Cayman Islands ring fitted at
//!   100 m passed within a centimetre of its own vertex, and 7 decimals put the vertex on the edge.
//!
//! The callers (per-feature rings, shared arcs) refit the lines of each new meeting at a tighter
//! tolerance, and at the last round as close to the input as the output's precision writes it,
//! so that output is valid wherever the input is.

use std::sync::OnceLock;

use geo::{coord, Intersects, Line};
use rayon::prelude::*;

use crate::earth::lonlat::{round_to, unit_to_lonlat};
use crate::sphere::geometry::crossing::{
    meeting_segments_boxed, polylines_meet_boxed, RunBoxes, SegmentTest, GREAT_CIRCLE,
};

/// Planar segments `[lon, lat, 0]`: closed segments meet when they share any point.
const PLANAR: SegmentTest = SegmentTest {
    margin: no_margin,
    meets: planar_segments_meet,
};

fn no_margin(_: &[f64; 3], _: &[f64; 3]) -> f64 {
    0.0
}

fn planar_segments_meet(a: &[f64; 3], b: &[f64; 3], c: &[f64; 3], d: &[f64; 3]) -> bool {
    let line = |p: &[f64; 3], q: &[f64; 3]| {
        Line::new(coord! { x: p[0], y: p[1] }, coord! { x: q[0], y: q[1] })
    };
    line(a, b).intersects(&line(c, d))
}

/// How two lines meet, judged each way.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct Meeting {
    /// Their great-circle edges cross.
    pub on_sphere: bool,
    /// Their edges as drawn (and written) touch.
    pub in_plane: bool,
}

impl Meeting {
    /// Whether fitted lines that meet like this meet where their input (`before`) did not. A
    /// meeting in the plane is new where the input did not meet in the plane: that is what a
    /// GIS refuses. A crossing on the sphere is new where the input met neither way: an input
    /// ring pinched to a point (China's 10m outline touches itself) cannot be fitted without
    /// crossing or parting there except by keeping that vertex, so it excuses the crossing
    /// (the input is invalid anyway), while keeping the whole ring for it would store every
    /// vertex of China.
    pub(crate) fn is_new_since(self, before: Meeting) -> bool {
        (self.in_plane && !before.in_plane)
            || (self.on_sphere && !before.on_sphere && !before.in_plane)
    }
}

/// Lines (rings or arcs) judged for meeting, each as unit vectors and, once asked, as drawn
/// in the plane (most lines are never asked: see [`tighten`]).
pub(crate) struct Drawn<'a> {
    units: Vec<&'a [[f64; 3]]>,
    precision: Option<u32>,
    /// Each line's bounding box on the sphere (lo, hi), to skip pairs far apart without
    /// building their segment boxes.
    unit_box: Vec<Bounds>,
    /// Each line's segment boxes on the sphere, made on first use.
    unit_runs: Vec<OnceLock<RunBoxes>>,
    /// Each line drawn in the plane, with its box and segment boxes, made on first use.
    plane: Vec<OnceLock<Plane>>,
}

/// A line drawn in the plane: its positions, box and segment boxes.
type Plane = (Vec<[f64; 3]>, Bounds, RunBoxes);

/// An axis-aligned box: its lowest and highest corner.
type Bounds = ([f64; 3], [f64; 3]);

/// The box of points, grown by `margin`.
fn bounds(points: &[[f64; 3]], margin: f64) -> Bounds {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in points {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k] - margin);
            hi[k] = hi[k].max(p[k] + margin);
        }
    }
    (lo, hi)
}

fn boxes_meet(a: &Bounds, b: &Bounds) -> bool {
    (0..3).all(|k| a.0[k] <= b.1[k] && b.0[k] <= a.1[k])
}

/// A line's positions in the plane: longitude unwrapped along the line (an edge across ±180
/// stays short, as the cut a writer makes there keeps it), rounded to `precision` decimals when
/// given (as written), as read otherwise.
fn drawn(points: &[[f64; 3]], precision: Option<u32>) -> Vec<[f64; 3]> {
    let round = |x: f64| precision.map_or(x, |p| round_to(x, p));
    let mut out: Vec<[f64; 3]> = Vec::with_capacity(points.len());
    let mut shift = 0.0;
    let mut last = None;
    for p in points {
        let (lon, lat) = unit_to_lonlat(p);
        let (lon, lat) = (round(lon), round(lat));
        if let Some(prev) = last {
            let step: f64 = lon - prev;
            if step > 180.0 {
                shift -= 360.0;
            } else if step < -180.0 {
                shift += 360.0;
            }
        }
        last = Some(lon);
        out.push([lon + shift, lat, 0.0]);
    }
    out
}

impl<'a> Drawn<'a> {
    /// `lines` as unit vectors; `precision` as in [`drawn`].
    pub(crate) fn new(lines: Vec<&'a [[f64; 3]]>, precision: Option<u32>) -> Drawn<'a> {
        // A great-circle edge bulges out of its chord's box by its sagitta; rings here are made
        // of edges far shorter than a quarter turn, and 1e-3 (6 km) more than covers them.
        let unit_box = lines.iter().map(|l| bounds(l, 1e-3)).collect();
        let plane = lines.iter().map(|_| OnceLock::new()).collect();
        let unit_runs = lines.iter().map(|_| OnceLock::new()).collect();
        Drawn {
            units: lines,
            precision,
            unit_box,
            unit_runs,
            plane,
        }
    }

    fn plane(&self, a: usize) -> &Plane {
        self.plane[a].get_or_init(|| {
            let line = drawn(self.units[a], self.precision);
            let b = bounds(&line, 0.0);
            let runs = RunBoxes::of(&line, PLANAR.margin);
            (line, b, runs)
        })
    }

    fn unit_runs(&self, a: usize) -> &RunBoxes {
        self.unit_runs[a].get_or_init(|| RunBoxes::of(self.units[a], GREAT_CIRCLE.margin))
    }

    /// The pairs `(a, b)`, `a <= b`, of `lines` whose boxes on the sphere come within `grow`
    /// (radians, chord) of each other, each line with itself included: the only pairs that can
    /// meet once each line has moved by at most `grow / 2`. Found by sweeping the boxes in
    /// order of their lowest x, so a MultiPolygon of thousands of islands is not compared pair
    /// by pair.
    pub(crate) fn near_pairs(&self, lines: &[usize], grow: f64) -> Vec<(usize, usize)> {
        let mut order: Vec<usize> = lines.to_vec();
        order.sort_by(|&a, &b| self.unit_box[a].0[0].total_cmp(&self.unit_box[b].0[0]));
        let mut pairs = Vec::new();
        for (k, &a) in order.iter().enumerate() {
            pairs.push((a, a));
            let (lo, hi) = self.unit_box[a];
            let grown = (lo.map(|x| x - grow), hi.map(|x| x + grow));
            for &b in &order[k + 1..] {
                if self.unit_box[b].0[0] > grown.1[0] {
                    break;
                }
                if boxes_meet(&grown, &self.unit_box[b]) {
                    pairs.push((a.min(b), a.max(b)));
                }
            }
        }
        pairs.sort_unstable();
        pairs
    }

    /// Whether lines `a` and `b` (or line `a` with itself) meet: whether their great-circle
    /// edges cross, and whether their drawn edges touch. Edges that share an end (a ring's
    /// neighbouring edges, arcs at a junction) never count.
    pub(crate) fn meet(&self, a: usize, b: usize) -> Meeting {
        let same = a == b;
        let in_plane = || {
            let ((pa, ba, ra), (pb, bb, rb)) = (self.plane(a), self.plane(b));
            boxes_meet(ba, bb) && polylines_meet_boxed((pa, ra), (pb, rb), same, PLANAR)
        };
        let on_sphere = || {
            boxes_meet(&self.unit_box[a], &self.unit_box[b])
                && polylines_meet_boxed(
                    (self.units[a], self.unit_runs(a)),
                    (self.units[b], self.unit_runs(b)),
                    same,
                    GREAT_CIRCLE,
                )
        };
        Meeting {
            on_sphere: on_sphere(),
            in_plane: in_plane(),
        }
    }

    /// Whether every place where lines `a` and `b` of `self` meet lies within `grow` (radians,
    /// chord) of a place where lines `a` and `b` of `before` (their input) meet: a meeting the
    /// input had there too, which no fit within the tolerance can be asked to part.
    fn meets_only_near(&self, before: &Drawn<'_>, a: usize, b: usize, grow: f64) -> bool {
        // Where two segments meet: the common part of their boxes (a long edge's box would
        // hold every place along it).
        let places = |d: &Drawn<'_>, pairs: Vec<(usize, usize)>| -> Vec<Bounds> {
            pairs
                .into_iter()
                .map(|(i, j)| {
                    let (p, q) = (d.units[a], d.units[b]);
                    let (s, t) = (bounds(&p[i..=i + 1], 0.0), bounds(&q[j..=j + 1], 0.0));
                    (
                        std::array::from_fn(|k| s.0[k].max(t.0[k])),
                        std::array::from_fn(|k| s.1[k].min(t.1[k])),
                    )
                })
                .collect()
        };
        let theirs = places(before, before.meeting_segments(a, b));
        places(self, self.meeting_segments(a, b))
            .iter()
            .all(|(lo, hi)| {
                let grown = (lo.map(|x| x - grow), hi.map(|x| x + grow));
                theirs.iter().any(|t| boxes_meet(&grown, t))
            })
    }

    /// The segments of line `b` (as drawn, near the first position of ring `a`) when `b` has
    /// moved across that position since `before` (their input): a ring that came outside
    /// another ring (an islet off a coast, a hole's shell) and was fitted to lie inside it, or
    /// the other way, without any edges meeting. `None` when it has not, when `a` is not a
    /// ring, or when either line is drawn across ±180 (where this plane's rays do not hold).
    ///
    /// Judged by the parity of an eastward ray from the position across `b` now and before:
    /// both ends of a line are where they were (a coverage's junctions, a ring's seam), so the
    /// parity changes only where the line swept over the position. Fitted at 20 km, the 10m
    /// countries came back with nested shells (islets of Egypt, the United Kingdom, Bangladesh
    /// swallowed by their coast) and Azerbaijan's hole outside its shell, with no crossing.
    pub(crate) fn swept(
        &self,
        before: &Drawn<'_>,
        a: usize,
        b: usize,
        grow: f64,
    ) -> Option<Vec<usize>> {
        let ring = self.units[a];
        if a == b || ring.len() < 4 || ring.first() != ring.last() {
            return None;
        }
        // Most pairs are far apart: their boxes on the sphere say so before any is drawn.
        let q = ring[0];
        let holds = |bx: &Bounds| (0..3).all(|k| bx.0[k] <= q[k] && q[k] <= bx.1[k]);
        if !(holds(&self.unit_box[b]) || holds(&before.unit_box[b])) {
            return None;
        }
        let p = self.plane(a).0[0];
        let ((now, now_box, _), (then, then_box, _)) = (self.plane(b), before.plane(b));
        let inside = |bx: &Bounds| (0..2).all(|k| bx.0[k] <= p[k] && p[k] <= bx.1[k]);
        let plain = |bx: &Bounds| bx.0[0] >= -180.0 && bx.1[0] <= 180.0;
        if !(inside(now_box) || inside(then_box)) || !(plain(now_box) && plain(then_box)) {
            return None;
        }
        if p[0].abs() > 180.0 || ray_parity(now, p) == ray_parity(then, p) {
            return None;
        }
        // The segments that could have swept over it: within `grow` of it.
        let g_lat = grow.to_degrees();
        let g_lon = g_lat / p[1].to_radians().cos().max(0.01);
        let near: Vec<usize> = now
            .windows(2)
            .enumerate()
            .filter(|(_, w)| {
                let lo = |k: usize| w[0][k].min(w[1][k]);
                let hi = |k: usize| w[0][k].max(w[1][k]);
                lo(0) - g_lon <= p[0]
                    && p[0] <= hi(0) + g_lon
                    && lo(1) - g_lat <= p[1]
                    && p[1] <= hi(1) + g_lat
            })
            .map(|(i, _)| i)
            .collect();
        Some(if near.is_empty() {
            (0..now.len().saturating_sub(1)).collect()
        } else {
            near
        })
    }

    /// Where lines `a` and `b` meet, as [`meet`](Self::meet) judges them either way: the pairs
    /// `(i, j)` of a segment `i` of `a` (from its point `i` to `i + 1`) and a segment `j` of
    /// `b` that cross on the sphere or touch as drawn.
    pub(crate) fn meeting_segments(&self, a: usize, b: usize) -> Vec<(usize, usize)> {
        let same = a == b;
        let (pa, _, ra) = self.plane(a);
        let (pb, _, rb) = self.plane(b);
        let mut out = meeting_segments_boxed((pa, ra), (pb, rb), same, PLANAR);
        out.extend(meeting_segments_boxed(
            (self.units[a], self.unit_runs(a)),
            (self.units[b], self.unit_runs(b)),
            same,
            GREAT_CIRCLE,
        ));
        out.sort_unstable();
        out.dedup();
        out
    }
}

/// Refits the lines that meet where their input did not, until none does or `rounds` refit
/// rounds are spent: each round the lines of every new meeting are refitted by `refit(line,
/// tolerance_m, fit, segments)` at [`Rounds::tightened`] tolerances (`Ok(None)` keeps the earlier fit
/// `fit`), where `segments` lists (ascending) the segments of the line's `dense` points that meet (segment
/// `i` from point `i` to `i + 1`), for a caller that refits only there. Only pairs with a
/// refitted line are judged again, and the input is judged only for pairs whose output meets.
/// Returns each line's tolerance and the meetings left.
///
/// # Errors
/// The first error of `refit`.
pub(crate) fn tighten<T: Send + Sync, E: Send>(
    input: &Drawn<'_>,
    pairs: &[(usize, usize)],
    tolerance_m: f64,
    rounds: Rounds,
    fitted: &mut [T],
    dense: impl Fn(&T) -> &[[f64; 3]] + Sync,
    refit: impl Fn(usize, f64, &T, &[usize]) -> Result<Option<T>, E> + Sync,
) -> Result<Tightened, E> {
    let mut tolerance = vec![tolerance_m; fitted.len()];
    // Fitted lines lie within the tolerance of their input, so a meeting the input has shows
    // within twice of it.
    let near = 2.0 * crate::earth::lonlat::m_to_rad(tolerance_m);
    let mut judged: Vec<(usize, usize)> = pairs.to_vec();
    for round in 0..=rounds.rounds {
        let output = Drawn::new(fitted.iter().map(&dense).collect(), input.precision);
        let meeting: Vec<(usize, usize)> = judged
            .par_iter()
            .filter(|&&(a, b)| {
                let now = output.meet(a, b);
                if now == Meeting::default() {
                    return false;
                }
                // Excused only near where the input meets too: an arc of India's 10m coast
                // that touches itself in one delta excused its fit's folds in another. (With
                // rings refitted whole this cost rings fitted per feature 30 % more numbers;
                // refitted around their meetings, 0.4 % at 1 km on the 10m countries, for 16
                // more valid features of 255.)
                let before = input.meet(a, b);
                now.is_new_since(before)
                    || (before != Meeting::default() && !output.meets_only_near(input, a, b, near))
            })
            .copied()
            .collect();
        // A ring on the other side of a line than its input was, with no edges meeting: the
        // line is refitted where it swept over the ring (`(line, ring, segments)`).
        let swept: Vec<(usize, usize, Vec<usize>)> = judged
            .par_iter()
            .flat_map_iter(|&(a, b)| {
                let output = &output;
                [(a, b), (b, a)]
                    .into_iter()
                    .filter_map(move |(ring, line)| {
                        output
                            .swept(input, ring, line, near)
                            .map(|at| (line, ring, at))
                    })
            })
            .collect();
        if (meeting.is_empty() && swept.is_empty()) || round == rounds.rounds {
            let mut left = meeting;
            left.extend(swept.iter().map(|&(l, r, _)| (l.min(r), l.max(r))));
            left.sort_unstable();
            left.dedup();
            return Ok(Tightened {
                tolerance_m: tolerance,
                left,
            });
        }
        let mut redo: Vec<usize> = meeting.iter().flat_map(|&(a, b)| [a, b]).collect();
        redo.extend(swept.iter().map(|&(line, _, _)| line));
        redo.sort_unstable();
        redo.dedup();
        // Each refitted line's meeting segments.
        let mut segments: std::collections::HashMap<usize, Vec<usize>> = Default::default();
        for (line, _, at) in &swept {
            segments.entry(*line).or_default().extend(at);
        }
        let found: Vec<Vec<(usize, usize)>> = meeting
            .par_iter()
            .map(|&(a, b)| output.meeting_segments(a, b))
            .collect();
        for (&(a, b), pairs) in meeting.iter().zip(found) {
            for (i, j) in pairs {
                segments.entry(a).or_default().push(i);
                segments.entry(b).or_default().push(j);
            }
        }
        for s in segments.values_mut() {
            s.sort_unstable();
            s.dedup();
        }
        let refits: Vec<(usize, f64, Option<T>)> = redo
            .par_iter()
            .map(|&i| {
                let t = rounds.tightened(tolerance[i], round);
                let at = segments.get(&i).map_or(&[][..], Vec::as_slice);
                refit(i, t, &fitted[i], at).map(|f| (i, t, f))
            })
            .collect::<Result<_, _>>()?;
        for (i, t, f) in refits {
            tolerance[i] = t;
            if let Some(f) = f {
                fitted[i] = f;
            }
        }
        judged = pairs
            .iter()
            .filter(|(a, b)| redo.binary_search(a).is_ok() || redo.binary_search(b).is_ok())
            .copied()
            .collect();
    }
    Ok(Tightened {
        tolerance_m: tolerance,
        left: Vec::new(),
    })
}

/// Whether an eastward ray from `p` crosses the drawn `line` an odd number of times (each
/// segment counted half-open in latitude, so a ray through a vertex counts once).
fn ray_parity(line: &[[f64; 3]], p: [f64; 3]) -> bool {
    let mut odd = false;
    for w in line.windows(2) {
        let (a, b) = (w[0], w[1]);
        if (a[1] > p[1]) != (b[1] > p[1]) {
            let x = a[0] + (p[1] - a[1]) * (b[0] - a[0]) / (b[1] - a[1]);
            if x > p[0] {
                odd = !odd;
            }
        }
    }
    odd
}

/// What [`tighten`] did.
pub(crate) struct Tightened {
    /// The tolerance each line was last fitted to, metres.
    pub tolerance_m: Vec<f64>,
    /// The pairs of lines still meeting after the last round.
    pub left: Vec<(usize, usize)>,
}

/// The tolerance of the last refit of a line that still meets another: a centimetre, the
/// resolution of 7 decimals, where the fit keeps the input's own vertices and so is valid
/// wherever the input is.
pub const LAST_RESORT_M: f64 = 0.01;

/// Where a line's `dense` points meet themselves as written at `precision` decimals (pairs of
/// segments).
fn self_meetings(dense: &[[f64; 3]], precision: u32) -> Vec<(usize, usize)> {
    Drawn::new(vec![dense], Some(precision)).meeting_segments(0, 0)
}

/// How many old vertices either side of a meeting a line fitted at `tolerance_m` and refitted
/// at `t` around its meetings only refits: a meeting that a window pinned at the old vertices
/// next to it did not part may need more room as the tolerance falls, round by round (T/2:
/// one vertex each side, T/4: two, T/16: four, T/64: six).
fn splice_margin(tolerance_m: f64, t: f64) -> usize {
    (tolerance_m / t).log2().ceil().max(1.0) as usize
}

/// A line (drawn as `old_dense`, fitted at `tolerance_m`) refitted at `t` around its meeting
/// segments `at` only, by `splice(segments, margin)` ([`crate::earth::polygon::splice_windows`]
/// for rings per feature and shared arcs alike); `None` when the caller should refit the whole
/// line. The line's own meetings are refitted with it: such a meeting is excused when its input
/// touches itself anywhere, and a whole refit used to part it by the way (world-atlas
/// countries-10m at 5 km: India's, Sweden's, Myanmar's and Venezuela's coasts). A window pinned
/// at the old vertices can fold back across the line's own segments there, so a splice is kept
/// only when `accept` takes it and it meets itself at no more segments than before; one that
/// folds is tried again with windows twice as wide, then four times (countries-10m coverage at
/// 5 km: 29 of 495 splices folded so; widened, it stores 86,604 numbers rather than 90,498, and
/// 49,458 rather than 60,640 at 20 km).
pub(crate) fn splice_around<T, E>(
    (old_dense, at): (&[[f64; 3]], &[usize]),
    (tolerance_m, t, precision): (f64, f64, u32),
    dense: impl Fn(&T) -> &[[f64; 3]],
    mut splice: impl FnMut(&[usize], usize) -> Result<Option<T>, E>,
    accept: impl Fn(&T) -> bool,
) -> Result<Option<T>, E> {
    let old_self = self_meetings(old_dense, precision);
    let mut at = at.to_vec();
    at.extend(old_self.iter().flat_map(|&(i, j)| [i, j]));
    at.sort_unstable();
    at.dedup();
    let margin = splice_margin(tolerance_m, t);
    for widen in [1, 2, 4] {
        let Some(f) = splice(&at, widen * margin)? else {
            return Ok(None);
        };
        if accept(&f) && self_meetings(dense(&f), precision).len() <= old_self.len() {
            return Ok(Some(f));
        }
    }
    Ok(None)
}

/// How many refit rounds `tighten` may spend, and how many of the last ones refit at
/// [`LAST_RESORT_M`].
#[derive(Clone, Copy, Debug)]
pub struct Rounds {
    /// Refit rounds in all.
    pub rounds: usize,
    /// The last rounds of them that refit at [`LAST_RESORT_M`].
    pub last_resort: usize,
}

/// The refit rounds of lines that meet (a shared arc, a ring fitted per feature), before a
/// meeting is reported as left (`crossings_left`): T/2, T/4, T/16, T/64, then two rounds as
/// written from the input. Lines are refitted around their meetings only, and the first
/// round at the last resort is such a splice too, with wide windows; the second refits whole
/// lines. A line refitted so lies on its input and may then meet a neighbour that was refitted
/// only around its own meetings, at a coarser tolerance, which the second round refits so too
/// (world-atlas countries-10m coverage at 20 km: four pairs left with one such round, none with
/// two). Splicing at the first of them stored Greenland's 10m ring (15,536 positions) at 5 km
/// in 4,213 numbers, where the whole ring at 1 cm would keep every position, and the 10m
/// countries' coverage at 20 km in 60,640 numbers rather than 73,872 (before a splice that
/// folds was tried again with wider windows: 49,458 since).
pub(crate) const REFIT_ROUNDS: Rounds = Rounds {
    rounds: 6,
    last_resort: 2,
};

impl Rounds {
    /// The tolerance of refit round `round` (0-based) of a line last fitted at `tolerance_m`:
    /// half of it for the first two rounds (an island off a coast parts at T/2 or T/4), a
    /// quarter after (Chile's 10m fjords at 1 km part only at T/32), and [`LAST_RESORT_M`] at
    /// the last [`Rounds::last_resort`] rounds.
    pub fn tightened(self, tolerance_m: f64, round: usize) -> f64 {
        if round + self.last_resort >= self.rounds {
            LAST_RESORT_M.min(tolerance_m)
        } else if round < 2 {
            0.5 * tolerance_m
        } else {
            0.25 * tolerance_m
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::earth::lonlat::lonlat_to_unit;

    fn ring(ll: &[(f64, f64)]) -> Vec<[f64; 3]> {
        ll.iter()
            .map(|&(lon, lat)| lonlat_to_unit(lon, lat))
            .collect()
    }

    #[test]
    fn a_vertex_rounded_onto_an_edge_touches_it_in_the_plane_only() {
        // The vertex (0.5, 1e-9) is a nanodegree off the edge (0,0)-(1,0): apart on the sphere
        // and as read, on the edge once written at 7 decimals.
        let r = ring(&[
            (0.0, 0.0),
            (1.0, 0.0),
            (1.0, 1.0),
            (0.5, 1e-9),
            (0.0, 1.0),
            (0.0, 0.0),
        ]);
        let before = Drawn::new(vec![&r], None).meet(0, 0);
        assert_eq!(before, Meeting::default());
        let after = Drawn::new(vec![&r], Some(7)).meet(0, 0);
        assert!(after.in_plane && !after.on_sphere && after.is_new_since(before));
    }

    #[test]
    fn rings_apart_do_not_meet_and_crossing_rings_do() {
        let a = ring(&[(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0), (0.0, 0.0)]);
        let b = ring(&[(2.0, 0.0), (3.0, 0.0), (3.0, 1.0), (2.0, 1.0), (2.0, 0.0)]);
        let c = ring(&[(0.5, 0.5), (1.5, 0.5), (1.5, 1.5), (0.5, 1.5), (0.5, 0.5)]);
        let d = Drawn::new(vec![&a, &b, &c], Some(7));
        assert_eq!(d.meet(0, 1), Meeting::default());
        assert_eq!(d.meet(0, 0), Meeting::default());
        let crossing = d.meet(0, 2);
        assert!(crossing.on_sphere && crossing.in_plane);
        assert_eq!(
            d.near_pairs(&[0, 1, 2], 1e-6),
            vec![(0, 0), (0, 2), (1, 1), (2, 2)]
        );
    }

    #[test]
    fn a_meeting_is_excused_only_near_where_the_input_meets() {
        // The input ring touches itself at (0.5, 0): a vertex on its own edge. One fit
        // crosses that edge there; another keeps the touch and crosses it 2.5° away too,
        // where the input does not meet.
        let input = ring(&[
            (0.0, 0.0),
            (4.0, 0.0),
            (4.0, 1.0),
            (1.0, 1.0),
            (0.5, 0.0),
            (0.0, 1.0),
            (0.0, 0.0),
        ]);
        let near = ring(&[
            (0.0, 0.0),
            (4.0, 0.0),
            (4.0, 1.0),
            (1.0, 1.0),
            (0.5, -0.05),
            (0.0, 1.0),
            (0.0, 0.0),
        ]);
        let far = ring(&[
            (0.0, 0.0),
            (4.0, 0.0),
            (4.0, 1.0),
            (3.0, -0.2),
            (3.0, 1.0),
            (1.0, 1.0),
            (0.5, 0.0),
            (0.0, 1.0),
            (0.0, 0.0),
        ]);
        let before = Drawn::new(vec![&input], Some(7));
        assert!(before.meet(0, 0).in_plane);
        let grow = 0.3_f64.to_radians();
        let (near, far) = (
            Drawn::new(vec![&near], Some(7)),
            Drawn::new(vec![&far], Some(7)),
        );
        assert!(near.meet(0, 0).in_plane && far.meet(0, 0).in_plane);
        assert!(near.meets_only_near(&before, 0, 0, grow));
        assert!(!far.meets_only_near(&before, 0, 0, grow));
    }

    #[test]
    fn a_ring_across_the_antimeridian_is_drawn_unwrapped() {
        // Edges from 179.5 to -179.5 are 1° long, not 359°: the ring does not meet itself.
        let r = ring(&[
            (179.0, 0.0),
            (-179.0, 0.0),
            (-179.0, 1.0),
            (179.0, 1.0),
            (179.0, 0.0),
        ]);
        assert_eq!(Drawn::new(vec![&r], Some(7)).meet(0, 0), Meeting::default());
    }

    #[test]
    fn a_line_that_swept_over_a_ring_is_found_and_refitted_there() {
        // A coast along the equator and an islet 0.2 degrees north of it. Fitted, the coast
        // bulges 0.5 degrees north round the islet: no edges meet, but the islet is now on the
        // coast's other side (nested in its shell, were the coast a ring).
        let coast_in = ring(&[(0.0, 0.0), (2.0, 0.0), (4.0, 0.0), (6.0, 0.0), (8.0, 0.0)]);
        let islet = ring(&[(3.9, 0.2), (4.1, 0.2), (4.0, 0.3), (3.9, 0.2)]);
        let coast_out = ring(&[(0.0, 0.0), (3.0, 0.0), (4.0, 0.5), (5.0, 0.0), (8.0, 0.0)]);
        let input = Drawn::new(vec![&coast_in, &islet], Some(7));
        let output = Drawn::new(vec![&coast_out, &islet], Some(7));
        assert_eq!(output.meet(0, 1), Meeting::default());
        let grow = 0.5f64.to_radians();
        // The coast's segments near the islet; the islet is no line that can sweep.
        assert_eq!(output.swept(&input, 1, 0, grow), Some(vec![1, 2]));
        assert_eq!(output.swept(&input, 0, 1, grow), None);
        assert_eq!(input.swept(&input, 1, 0, grow), None);
        // A bulge that stays south of the islet sweeps over nothing.
        let low = ring(&[(0.0, 0.0), (3.0, 0.0), (4.0, 0.1), (5.0, 0.0), (8.0, 0.0)]);
        assert_eq!(
            Drawn::new(vec![&low, &islet], Some(7)).swept(&input, 1, 0, grow),
            None
        );
        // tighten refits the coast only, where it swept, until it no longer does.
        let mut fitted = vec![coast_out.clone(), islet.clone()];
        let refits = std::sync::Mutex::new(Vec::new());
        let t = tighten(
            &input,
            &[(0, 0), (0, 1), (1, 1)],
            20_000.0,
            REFIT_ROUNDS,
            &mut fitted,
            |l: &Vec<[f64; 3]>| l.as_slice(),
            |line, _, _, at| {
                refits.lock().unwrap().push((line, at.to_vec()));
                Ok::<_, ()>(Some(if line == 0 {
                    low.clone()
                } else {
                    islet.clone()
                }))
            },
        )
        .unwrap();
        assert!(t.left.is_empty());
        assert_eq!(refits.into_inner().unwrap(), vec![(0, vec![1, 2])]);
        assert_eq!(t.tolerance_m, vec![10_000.0, 20_000.0]);
    }
}
