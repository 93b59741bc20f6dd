//! Dense sampling of a curve with a proven deviation bound: a polyline of great-circle chords
//! through curve points such that every point of the curve is within `deviation_rad` of the
//! polyline and every point of the polyline within `deviation_rad` of the curve.
//!
//! Chords are halved only where the bound asks for it, so bends get many points and straight
//! stretches few (a degree-1 spline comes out as its control polygon). A chord is certified by
//! the spherical-ellipse bound of [`super::bounds::ellipse_deviation`] from the curve's speed
//! bound, and, where that is loose, by a few interior samples: on a sub-interval the curve is
//! within the ellipse bound of the sub-chord, which in turn is within
//! `arc_to_arc_sup` of the chord (or the Lipschitz bound of the distance,
//! whichever is smaller). Proofs: `docs/certified-distance.md`.

use crate::sphere::certify::bounds::{
    acceleration_deviation, arc_to_arc_known, ellipse_deviation, ROUNDING_SLACK_RAD,
};
use crate::sphere::curve::{even_parameters, SphericalCurve};
use crate::sphere::geometry::arc::ArcFrame;
use crate::sphere::geometry::point::{angle_between, Dynamic, PointSet};
use rayon::prelude::*;
use smallvec::{smallvec, SmallVec};

/// Interior samples spent on certifying one chord before the chord is halved instead.
const CHORD_EVALUATIONS: usize = 24;

/// Interior samples per chord once the point limit is reached (the bound is then only
/// tightened, never assumed).
const FINAL_CHORD_EVALUATIONS: usize = 512;

/// Curve evaluations allowed per output point allowed (`max_points`): the halving and the
/// certification stop there, and the deviation returned is the bound proven by then. Without
/// it a long curve at a tight tolerance whose speed bound is loose (control arcs near a half
/// turn) would spend up to `FINAL_CHORD_EVALUATIONS` on every one of `max_points` chords.
const EVALUATIONS_PER_POINT: usize = 8;

/// A curve sampled with a certified deviation.
#[derive(Clone, Debug)]
pub struct DenseSamples {
    /// Curve parameters of the output points, ascending, domain ends included.
    pub params: Vec<f64>,
    /// The output points (unit vectors).
    pub points: PointSet,
    /// Proven bound of the two-way distance between the curve and the polyline (radians).
    pub deviation_rad: f64,
    /// Curve evaluations made (output points and certification samples).
    pub evaluations: usize,
}

/// Samples `curve` so that the polyline through the samples is within `tolerance_rad` of the
/// curve both ways, starting from `start` evenly spaced parameters plus the curve's
/// [`breaks`](SphericalCurve::breaks) and halving chords whose bound exceeds the tolerance.
/// At most `max_points` points (at least 2): when the limit stops the halving, the deviation
/// returned is the (larger) bound actually proven.
///
/// # Example
/// ```
/// use spherefit::sphere::certify::dense::sample_within;
/// use spherefit::sphere::{PointSet, SphericalBSpline};
/// let ctrl = PointSet::try_from_rows(&[[1.0, 0.0, 0.0], [0.6, 0.8, 0.0], [0.0, 0.6, 0.8]]).unwrap();
/// let s = SphericalBSpline::try_new(2, vec![0.0, 0.0, 0.0, 1.0, 1.0, 1.0], ctrl).unwrap();
/// let d = sample_within(&s, 1e-5, 4, 100_000);
/// assert!(d.deviation_rad <= 1e-5);
/// ```
pub fn sample_within(
    curve: &dyn SphericalCurve,
    tolerance_rad: f64,
    start: usize,
    max_points: usize,
) -> DenseSamples {
    let budget = EVALUATIONS_PER_POINT.saturating_mul(max_points.max(2));
    sample_within_budget(curve, tolerance_rad, start, max_points, budget)
}

/// [`sample_within`] with at most about `max_evaluations` curve evaluations (at least one per
/// output point): past it, chords keep the bound proven so far, which is what
/// `deviation_rad` then reports (it may exceed `tolerance_rad`, never the truth).
pub fn sample_within_budget(
    curve: &dyn SphericalCurve,
    tolerance_rad: f64,
    start: usize,
    max_points: usize,
    max_evaluations: usize,
) -> DenseSamples {
    let max_points = max_points.max(2);
    let tol = tolerance_rad.max(2.0 * ROUNDING_SLACK_RAD);
    let (lo, hi) = curve.domain();
    let mut ts = even_parameters((lo, hi), start.clamp(2, max_points));
    let breaks = curve.breaks();
    let all_breaks = ts.len() + breaks.len() <= max_points;
    if all_breaks {
        ts.extend(breaks);
        ts.sort_by(f64::total_cmp);
        ts.dedup();
    }
    let dim = curve.dim();
    if all_breaks && curve.as_polyline().is_some() {
        // Every chord is a stretch of one of the curve's great-circle arcs, run at constant
        // speed: the ellipse bound with the curve's length equal to the chord leaves only the
        // rounding slack of the points and of measuring against a short chord.
        let points = curve.evaluate_many(&ts);
        let evaluations = ts.len();
        let deviation_rad = (1..ts.len())
            .map(|i| {
                let c = angle_between(points.get(i - 1), points.get(i));
                ellipse_deviation(c, c)
            })
            .fold(ROUNDING_SLACK_RAD, f64::max);
        return DenseSamples {
            params: ts,
            points,
            deviation_rad,
            evaluations,
        };
    }
    let mut pts = curve.evaluate_many(&ts).as_flat().to_vec();
    let mut evaluations = ts.len();
    // Chords waiting for a verdict, as indices of their start in (ts, pts); accepted chords
    // keep their bound.
    let mut bound = vec![f64::NAN; ts.len() - 1];
    let mut pending: Vec<usize> = (0..ts.len() - 1).collect();
    let mut budget = max_evaluations;
    // Cancelled work (the caller's token) ends the halving: the bound proven so far stands.
    let token = crate::sphere::cancel::current();
    loop {
        if token.is_cancelled() {
            budget = budget.min(evaluations);
        }
        let last_round = ts.len() >= max_points || evaluations >= budget;
        let cap = if last_round {
            FINAL_CHORD_EVALUATIONS.min(budget.saturating_sub(evaluations) / pending.len().max(1))
        } else {
            CHORD_EVALUATIONS
        };
        let verdicts: Vec<ChordVerdict> = pending
            .par_iter()
            .map(|&i| {
                certify_chord(
                    curve,
                    ts[i],
                    ts[i + 1],
                    &pts[i * dim..(i + 1) * dim],
                    &pts[(i + 1) * dim..(i + 2) * dim],
                    ChordEffort {
                        tol,
                        cap,
                        may_split: !last_round,
                    },
                )
            })
            .collect();
        let mut split: Vec<usize> = Vec::new();
        let mut pieces = vec![0usize; ts.len() - 1];
        for (&i, v) in pending.iter().zip(&verdicts) {
            evaluations += v.evaluations;
            bound[i] = v.bound;
            if v.bound > tol && !last_round {
                split.push(i);
                pieces[i] = v.pieces;
            }
        }
        let room = max_points - ts.len();
        if split.is_empty() || room == 0 {
            if room == 0 && !split.is_empty() {
                continue;
            }
            break;
        }
        if evaluations >= budget {
            // The final round re-certifies what is still open with what budget is left.
            pending = split;
            continue;
        }
        if split.len() > room {
            split.sort_by(|&a, &b| bound[b].total_cmp(&bound[a]));
            split.truncate(room);
            split.sort_unstable();
        }
        // Each split chord is cut into the pieces its verdict asked for (at least two), as
        // many as the point limit leaves room for.
        let mut room = room;
        let mut cuts: Vec<usize> = Vec::with_capacity(split.len());
        for (n, &i) in split.iter().enumerate() {
            // Every chord still to cut keeps room for its own midpoint.
            let later = split.len() - n - 1;
            let c = (pieces[i] - 1).min(room - later).max(1);
            room -= c;
            cuts.push(c);
        }
        let mut mids: Vec<f64> = Vec::with_capacity(cuts.iter().sum());
        for (&i, &c) in split.iter().zip(&cuts) {
            let (a, b) = (ts[i], ts[i + 1]);
            mids.extend((1..=c).map(|k| a + (b - a) * (k as f64 / (c + 1) as f64)));
        }
        let mid_pts = curve.evaluate_many(&mids);
        evaluations += mids.len();
        // Merge the cut points in; the pieces of each split chord are pending.
        let mut ts2 = Vec::with_capacity(ts.len() + mids.len());
        let mut pts2 = Vec::with_capacity(pts.len() + mids.len() * dim);
        let mut bound2 = Vec::with_capacity(bound.len() + mids.len());
        let mut pending2 = Vec::with_capacity(split.len() + mids.len());
        let (mut k, mut m) = (0, 0);
        for i in 0..ts.len() {
            ts2.push(ts[i]);
            pts2.extend_from_slice(&pts[i * dim..(i + 1) * dim]);
            if i + 1 == ts.len() {
                break;
            }
            if k < split.len() && split[k] == i {
                pending2.push(bound2.len());
                bound2.push(f64::NAN);
                for _ in 0..cuts[k] {
                    ts2.push(mids[m]);
                    pts2.extend_from_slice(mid_pts.get(m));
                    pending2.push(bound2.len());
                    bound2.push(f64::NAN);
                    m += 1;
                }
                k += 1;
            } else {
                bound2.push(bound[i]);
            }
        }
        ts = ts2;
        pts = pts2;
        bound = bound2;
        pending = pending2;
    }
    let deviation_rad = bound.iter().copied().fold(0.0, f64::max);
    DenseSamples {
        params: ts,
        points: PointSet::from_flat_unchecked(dim, pts),
        deviation_rad,
        evaluations,
    }
}

/// What [`certify_chord`] aims for and may spend.
#[derive(Clone, Copy)]
struct ChordEffort {
    /// The bound wanted (radians).
    tol: f64,
    /// Most interior evaluations.
    cap: usize,
    /// Whether the caller will halve a chord that fails (not in the last round).
    may_split: bool,
}

/// Most pieces a failed chord is cut into at once.
const MAX_PIECES: usize = 16;

/// A failed chord is cut into pieces expected to deviate this share of the tolerance: the
/// deviation of a piece falls with the square of its width, so a sample `g` from the chord
/// asks for about `sqrt(g / (share tol))` pieces instead of the two of a halving (whose
/// pieces often fail again: with halving, the 10m US–Mexico border took 4,191 certifications
/// for 2,279 final chords, so about 1,900 of them failed). Measured there (callgrind): a
/// share of 0.5 cost 2.7 % fewer instructions than
/// 1 but 8.5 % more output points (2,540 against 2,340; 2,280 with halving), 4 cost 2.7 %
/// more instructions for 2,294 points.
const PIECE_AIM_SHARE: f64 = 1.0;

/// What [`certify_chord`] proved about a chord.
#[derive(Clone, Copy)]
struct ChordVerdict {
    /// The bound proven (radians).
    bound: f64,
    /// Interior evaluations made.
    evaluations: usize,
    /// When the chord fails: how many pieces to cut it into (at least 2).
    pieces: usize,
}

/// A proven bound of the two-way distance between the curve on `[u, v]` and the chord
/// `pu`–`pv`, spending at most `cap` interior evaluations.
/// With `may_split`, a sample farther than `tol` from the chord ends the work early (no
/// bound can then be within `tol`, and the caller cuts the chord, into more than two pieces
/// when the sample is far beyond `tol`): the bound returned is the one proven before the
/// sampling.
fn certify_chord(
    curve: &dyn SphericalCurve,
    u: f64,
    v: f64,
    pu: &[f64],
    pv: &[f64],
    effort: ChordEffort,
) -> ChordVerdict {
    let ChordEffort {
        tol,
        cap,
        may_split,
    } = effort;
    let verdict = |bound: f64, evaluations: usize| ChordVerdict {
        bound,
        evaluations,
        pieces: 2,
    };
    if v <= u {
        return verdict(0.0, 0);
    }
    let chord = angle_between(pu, pv);
    // Within a knot span the acceleration bound settles most chords at once; the speed bound
    // (and its sub-intervals) is the fallback across joints and near half turns.
    let accel = curve.acceleration_bound(u, v);
    let second = acceleration_deviation(accel, v - u, chord);
    if second <= tol {
        return verdict(second, 0);
    }
    // With an acceleration bound the sub-intervals below are judged by it; the speed bound
    // (a call as costly as the acceleration bound) is only needed without one.
    let speed = if accel.is_finite() {
        f64::INFINITY
    } else {
        curve.speed_bound(u, v)
    };
    // Any two points of the sphere are within pi: the bound when the speed bound is not finite.
    let whole = ellipse_deviation(speed * (v - u), chord)
        .min(second)
        .min(std::f64::consts::PI);
    if whole <= tol {
        return verdict(whole, 0);
    }
    let dim = pu.len();
    let frame = ArcFrame::new(Dynamic(dim), pu, pv);
    // (t, point, distance to the chord), on the stack for the usual few cuts: most chords
    // that get here settle after one to three levels, thousands of them per curve.
    let mut ts: SmallVec<[f64; 16]> = smallvec![u, v];
    let mut pts: SmallVec<[f64; 48]> = SmallVec::from_slice(pu);
    pts.extend_from_slice(pv);
    let mut gs: SmallVec<[f64; 16]> = smallvec![0.0, 0.0];
    // Open sub-intervals with the speed bound of the interval they were split from: a bound
    // over an interval holds on every part of it, so a part is first judged with its parent's
    // bound and gets its own (tighter, and the costly step) only when that does not settle it.
    let mut open: SmallVec<[(usize, usize, f64); 8]> = smallvec![(0usize, 1usize, speed)];
    let mut split: SmallVec<[(usize, usize, f64); 8]> = SmallVec::new();
    let mut mids: SmallVec<[f64; 8]> = SmallVec::new();
    let mut mp: SmallVec<[f64; 24]> = SmallVec::new();
    let mut accepted: f64 = 0.0;
    let mut evaluations = 0;
    // With an acceleration bound the whole chord's bound below would be `second` (the chord
    // is its own arc, and no speed bound was taken), which already failed: halve at once.
    let mut whole_failed = accel.is_finite();
    loop {
        split.clear();
        let mut worst_open: f64 = 0.0;
        for &(a, b, parent_speed) in &open {
            if std::mem::take(&mut whole_failed) {
                worst_open = whole;
                split.push((a, b, parent_speed));
                continue;
            }
            let (pa, pb) = (&pts[a * dim..(a + 1) * dim], &pts[b * dim..(b + 1) * dim]);
            let chord = angle_between(pa, pb);
            // The ends' distances to the chord are known (`gs`): only the cut points cost.
            let ends = (gs[a], gs[b]);
            let sup = crate::with_dim!(dim, |d| arc_to_arc_known(d, pa, pb, chord, ends, &frame)).0;
            // The acceleration bound over [u, v] holds on every part of it.
            let bent = acceleration_deviation(accel, ts[b] - ts[a], chord) + sup;
            let bound_with = |speed: f64| {
                let length = speed * (ts[b] - ts[a]);
                let lip = 0.5 * (gs[a] + gs[b] + length) + ROUNDING_SLACK_RAD;
                lip.min(ellipse_deviation(length, chord) + sup).min(bent)
            };
            let mut own = parent_speed;
            let mut bd = bound_with(own);
            if bd > tol && !accel.is_finite() {
                own = curve.speed_bound(ts[a], ts[b]).min(parent_speed);
                bd = bound_with(own);
            }
            if bd <= tol || ts[b] - ts[a] <= 1e-13 * ts[a].abs().max(ts[b].abs()).max(1.0) {
                accepted = accepted.max(bd);
            } else {
                worst_open = worst_open.max(bd);
                split.push((a, b, own));
            }
        }
        if split.is_empty() {
            return verdict(accepted.min(whole), evaluations);
        }
        if evaluations + split.len() > cap {
            return verdict(accepted.max(worst_open).min(whole), evaluations);
        }
        mids.clear();
        mids.extend(split.iter().map(|&(a, b, _)| 0.5 * (ts[a] + ts[b])));
        mp.clear();
        mp.resize(mids.len() * dim, 0.0);
        curve.evaluate_into(&mids, &mut mp);
        evaluations += mids.len();
        open.clear();
        for (k, &(a, b, speed)) in split.iter().enumerate() {
            let p = &mp[k * dim..(k + 1) * dim];
            ts.push(mids[k]);
            pts.extend_from_slice(p);
            let g = frame.distance_dyn(p);
            if may_split && g > tol {
                // A curve point this far from the chord: the chord fails whatever the bound.
                let pieces = (g / (PIECE_AIM_SHARE * tol)).sqrt().ceil();
                return ChordVerdict {
                    bound: whole.max(g),
                    evaluations,
                    pieces: (pieces as usize).clamp(2, MAX_PIECES),
                };
            }
            gs.push(g);
            let m = ts.len() - 1;
            open.push((a, m, speed));
            open.push((m, b, speed));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sphere::geometry::arc::distance_to_arc;
    use crate::sphere::SphericalBSpline;
    use proptest::prelude::*;

    fn ll(lon: f64, lat: f64) -> [f64; 3] {
        [lat.cos() * lon.cos(), lat.cos() * lon.sin(), lat.sin()]
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(24))]
        #[test]
        fn every_curve_point_is_within_the_deviation(
            p in 1usize..=3,
            n in 4usize..10,
            scale in 0.001f64..1.0,
            wave in 0.0f64..0.5,
            rel in 1e-5f64..1e-2,
        ) {
            let rows: Vec<[f64; 3]> = (0..n)
                .map(|i| ll(scale * i as f64 / n as f64, wave * scale * ((i * 37 % 11) as f64 / 11.0 - 0.5)))
                .collect();
            let m = n - p;
            let mut k = vec![0.0; p + 1];
            k.extend((1..m).map(|i| i as f64 / m as f64));
            k.extend(std::iter::repeat_n(1.0, p + 1));
            let c = SphericalBSpline::try_new(p, k, PointSet::try_from_rows(&rows).unwrap()).unwrap();
            let tol = rel * scale;
            let d = sample_within(&c, tol, 8, 1_000_000);
            prop_assert!(d.deviation_rad <= tol);
            // Independent check: dense curve samples against the chord holding their parameter.
            let ts: Vec<f64> = (0..=20_000).map(|i| i as f64 / 20_000.0).collect();
            let cs = c.evaluate_many(&ts);
            for (i, &t) in ts.iter().enumerate() {
                let j = d.params.partition_point(|&u| u <= t).clamp(1, d.params.len() - 1) - 1;
                let e = distance_to_arc(cs.get(i), d.points.get(j), d.points.get(j + 1));
                prop_assert!(e <= d.deviation_rad, "{e} > {}", d.deviation_rad);
            }
        }
    }

    #[test]
    fn a_polyline_comes_out_as_its_vertices_and_bends_get_more_points() {
        let rows: Vec<[f64; 3]> = (0..5)
            .map(|i| ll(0.1 * i as f64, 0.02 * (i % 2) as f64))
            .collect();
        let ctrl = PointSet::try_from_rows(&rows).unwrap();
        let k = vec![0.0, 0.0, 0.25, 0.5, 0.75, 1.0, 1.0];
        let line = SphericalBSpline::try_new(1, k, ctrl.clone()).unwrap();
        let d = sample_within(&line, 5e-8, 2, 10_000);
        assert_eq!(d.params, vec![0.0, 0.25, 0.5, 0.75, 1.0]);
        assert!(d.deviation_rad <= 5e-8);
        let k3 = vec![0.0, 0.0, 0.0, 0.0, 0.5, 1.0, 1.0, 1.0, 1.0];
        let cubic = SphericalBSpline::try_new(3, k3, ctrl).unwrap();
        let loose = sample_within(&cubic, 1e-4, 2, 10_000);
        let tight = sample_within(&cubic, 1e-6, 2, 10_000);
        assert!(tight.points.len() > 3 * loose.points.len());
    }

    #[test]
    fn the_point_limit_is_kept_and_the_bound_stays_honest() {
        let rows: Vec<[f64; 3]> = (0..6)
            .map(|i| ll(0.3 * i as f64, 0.2 * (i % 2) as f64))
            .collect();
        let k = vec![0.0, 0.0, 0.0, 0.0, 1.0 / 3.0, 2.0 / 3.0, 1.0, 1.0, 1.0, 1.0];
        let c = SphericalBSpline::try_new(3, k, PointSet::try_from_rows(&rows).unwrap()).unwrap();
        let d = sample_within(&c, 1e-9, 4, 40);
        assert!(d.points.len() <= 40);
        assert!(d.deviation_rad > 1e-9);
        let ts: Vec<f64> = (0..=5000).map(|i| i as f64 / 5000.0).collect();
        let cs = c.evaluate_many(&ts);
        for (i, &t) in ts.iter().enumerate() {
            let j = d
                .params
                .partition_point(|&u| u <= t)
                .clamp(1, d.params.len() - 1)
                - 1;
            assert!(
                distance_to_arc(cs.get(i), d.points.get(j), d.points.get(j + 1)) <= d.deviation_rad
            );
        }
    }
}
