//! Foot-point correction: each point's parameter moved towards the curve point nearest it.

use crate::sphere::compress::tolerance::fitter::Fitter;
use crate::sphere::curve::bspline::Degree;
use crate::sphere::geometry::arc::ArcFrame;
use crate::sphere::geometry::point::{angle_from_sine, dot, Dim};

impl<D: Dim, G: Degree> Fitter<'_, D, G> {
    /// Moves the parameters of points `j0 .. j1` towards their foot points (Newton on
    /// |q − C(t)|², central differences for C'), keeping them non-decreasing and the end points
    /// at 0 and 1. A step is kept only when it lowers that point's error.
    pub(super) fn correct_range(&mut self, j0: usize, j1: usize, steps: usize) {
        if !self.free {
            return;
        }
        if self.p() == 1 {
            // Each pass moves a foot point at most into the next span and holds it behind its
            // neighbour's parameter as that was: `steps` passes let the feet settle, so a
            // polyline seed meets its target without knot insertions (whole-curve refits).
            for _ in 0..steps {
                if !self.correct_range_polyline(j0, j1) {
                    break;
                }
            }
            return;
        }
        let n = self.points.len();
        let dim = self.d.get();
        for j in j0.max(1)..j1.min(n - 1) {
            let (lo, hi) = (self.params[j - 1], self.params[j + 1]);
            let mut t = self.params[j];
            let mut e = self.err[j];
            for _ in 0..steps {
                if e == 0.0 {
                    break;
                }
                let k = self.eval(t);
                let width = (self.knots[k + 1] - self.knots[k]).max(1e-12);
                let h = 1e-4 * width;
                // Forward difference inside the span (backward at its end): C' is smooth there.
                let (ta, tb) = if t + h <= self.knots[k + 1] {
                    (t, t + h)
                } else {
                    (t - h, t)
                };
                self.eval_into::<false>(tb, true);
                let mut dc = [0.0; 16];
                let mut heap = Vec::new();
                let dc: &mut [f64] = if dim <= 16 {
                    &mut dc[..dim]
                } else {
                    heap.resize(dim, 0.0);
                    &mut heap
                };
                dc.copy_from_slice(&self.c2[..dim]);
                let inv = 1.0 / (tb - ta);
                if ta == t {
                    for x in 0..dim {
                        dc[x] = (dc[x] - self.c[x]) * inv;
                    }
                } else {
                    self.eval_into::<false>(ta, true);
                    for x in 0..dim {
                        dc[x] = (dc[x] - self.c2[x]) * inv;
                    }
                }
                let q = self.points.get(j);
                let mut num = 0.0;
                for x in 0..dim {
                    num += (q[x] - self.c[x]) * dc[x];
                }
                let den = dot(self.d, dc, dc);
                if den <= 0.0 || !num.is_finite() {
                    break;
                }
                let tn = (t + num / den).clamp(lo, hi);
                if tn == t {
                    break;
                }
                let en = self.error_at(j, tn);
                if en < e {
                    t = tn;
                    e = en;
                } else {
                    break;
                }
            }
            self.params[j] = t;
            self.err[j] = e;
        }
    }

    /// [`correct_range`](Self::correct_range) for a polyline: the foot point on the arc of the
    /// span holding the parameter, in closed form (the arc's along-track angle over its
    /// length), instead of Newton steps with finite differences (three curve evaluations per
    /// point, a sixth of a coastline's fitting time). A foot beyond the span's end stops at
    /// its vertex; the next correction carries on from the next span. Kept non-decreasing
    /// and only where it lowers the point's error, as the Newton steps are.
    /// Returns whether any parameter moved.
    fn correct_range_polyline(&mut self, j0: usize, j1: usize) -> bool {
        let n = self.points.len();
        let last = self.last_span();
        let mut k = 1;
        let mut moved = false;
        // The frames of the spans in use (the control points do not move during a pass): the
        // points of a span are corrected in turn, each looking at its span and a neighbour.
        let mut frames: [Option<(usize, ArcFrame)>; 2] = [None, None];
        for j in j0.max(1)..j1.min(n - 1) {
            let e = self.err[j];
            if e == 0.0 {
                continue;
            }
            let (lo, hi) = (self.params[j - 1], self.params[j + 1]);
            let t = self.params[j];
            let Some((best, _)) = self.polyline_foot(&mut frames, &mut k, last, j) else {
                continue;
            };
            let (tn, side, dist) = best;
            let clamped = tn.clamp(lo, hi);
            if clamped == t {
                continue;
            }
            // On the arc and not held back by a neighbour's parameter: the distance is known
            // (evaluating the curve there gives the same to rounding); otherwise measure.
            let en = if side == 0 && clamped == tn && dist < 0.1 {
                dist
            } else {
                self.error_at(j, clamped)
            };
            if en < e {
                self.params[j] = clamped;
                self.err[j] = en;
                moved = true;
            }
        }
        moved
    }

    /// For a polyline after its control points moved (a refit's step): each point of
    /// `j0 .. j1` measured and moved to its foot point in one pass, instead of measured at its
    /// old parameter and then corrected ([`correct_range`](Self::correct_range)). A foot on the
    /// arc of the span the parameter is in is the nearest point of that span, so it is taken
    /// with its distance and the curve is not evaluated at the old parameter; a foot held back
    /// by a neighbour's parameter or on another span is kept only where it is nearer than the
    /// old parameter's point, as in [`correct_range`](Self::correct_range). Returns the max
    /// error and the weighted sum of squares, as [`measure_range`](Self::measure_range) does.
    pub(super) fn project_range_polyline(&mut self, j0: usize, j1: usize) -> (f64, f64) {
        let n = self.points.len();
        let last = self.last_span();
        let mut k = 1;
        let (mut max, mut sq): (f64, f64) = (0.0, 0.0);
        let mut frames: [Option<(usize, ArcFrame)>; 2] = [None, None];
        for j in j0..j1 {
            let t = self.params[j];
            let mut e = None;
            if j > 0 && j + 1 < n {
                let (lo, hi) = (self.params[j - 1], self.params[j + 1]);
                if let Some((best, same_span)) = self.polyline_foot(&mut frames, &mut k, last, j) {
                    let (tn, side, dist) = best;
                    let clamped = tn.clamp(lo, hi);
                    let on_arc = side == 0 && clamped == tn && dist < 0.1;
                    if on_arc && same_span {
                        self.params[j] = tn;
                        e = Some(dist);
                    } else {
                        let e_old = self.error_at(j, t);
                        let mut chosen = e_old;
                        if clamped != t {
                            let en = if on_arc {
                                dist
                            } else {
                                self.error_at(j, clamped)
                            };
                            if en < e_old {
                                self.params[j] = clamped;
                                chosen = en;
                            }
                        }
                        e = Some(chosen);
                    }
                }
            }
            let e = match e {
                Some(e) => e,
                None => self.error_at(j, t),
            };
            self.err[j] = e;
            max = max.max(e);
            sq += self.weight[j] * e * e;
        }
        (max, sq)
    }

    /// The foot of point `j` on the polyline (degree 1): on the arc of the span its parameter
    /// is in (`k`, moved there when it is not: the points of a pass come in order), or, past
    /// that arc's end or before its start, on the next arc or the one before. Returns the foot
    /// as [`foot_on_span`] does, and whether it is on the parameter's own span; `None` for a
    /// degenerate arc.
    fn polyline_foot(
        &self,
        frames: &mut [Option<(usize, ArcFrame)>; 2],
        k: &mut usize,
        last: usize,
        j: usize,
    ) -> Option<((f64, i8, f64), bool)> {
        let t = self.params[j];
        if !(self.knots[*k] <= t && (t < self.knots[*k + 1] || *k == last)) {
            *k = self
                .knots
                .partition_point(|&u| u <= t)
                .saturating_sub(1)
                .clamp(1, last);
        }
        let k = *k;
        let q = self.points.get(j);
        let mut foot = |k: usize| foot_on_span(self, frames, self.d, k, q);
        let best = foot(k)?;
        // Past a vertex: the foot may lie on the next arc (or the one before).
        let next = match best.1 {
            1 if k < last => foot(k + 1),
            -1 if k > 1 => foot(k - 1),
            _ => None,
        };
        Some(match next {
            Some(f @ (_, 0, _)) => (f, false),
            _ => (best, true),
        })
    }

    pub(in crate::sphere::compress::tolerance) fn correct_all(&mut self, steps: usize) {
        self.correct_range(0, self.points.len(), steps);
    }
}

/// The foot of `q` on the arc of span `k` of a polyline fitter, as (parameter, where it fell:
/// -1 before the arc's start, 1 past its end, 0 on it, and then `q`'s distance to it); `None`
/// for a degenerate or antipodal arc. `frames` keeps the arcs of the two spans last used.
fn foot_on_span<D: Dim, G: Degree>(
    f: &Fitter<'_, D, G>,
    frames: &mut [Option<(usize, ArcFrame)>; 2],
    d: D,
    k: usize,
    q: &[f64],
) -> Option<(f64, i8, f64)> {
    let (u0, u1) = (f.knots[k], f.knots[k + 1]);
    let slot = k % 2;
    if frames[slot].as_ref().is_none_or(|(s, _)| *s != k) {
        frames[slot] = Some((k, ArcFrame::new(d, f.ctrl.get(k - 1), f.ctrl.get(k))));
    }
    let arc = &frames[slot].as_ref().expect("set just above").1;
    if arc.degenerate() || arc.is_antipodal() || u1 <= u0 {
        return None;
    }
    let (x, y) = (dot(d, q, &arc.e1), dot(d, q, &arc.e2));
    // The along-track angle atan2(y, x), by its sine where it is small (a point near a short
    // arc), without libm's atan2.
    let r = (x * x + y * y).sqrt();
    let phi = if x > 0.0 && y.abs() <= 0.1 * r {
        angle_from_sine(y.abs() / r).copysign(y)
    } else {
        y.atan2(x)
    };
    let alpha = phi / arc.theta;
    if alpha < 0.0 {
        return Some((u0, -1, f64::NAN));
    }
    if alpha > 1.0 {
        return Some((u1, 1, f64::NAN));
    }
    // The curve point at the foot is q's projection on the arc's great circle: the error
    // there is the cross-track distance, asin |q - x e1 - y e2|.
    let mut perp_sq = 0.0;
    for c in 0..d.get() {
        let r = q[c] - x * arc.e1[c] - y * arc.e2[c];
        perp_sq += r * r;
    }
    let dist = angle_from_sine(perp_sq.sqrt());
    Some((u0 + alpha * (u1 - u0), 0, dist))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sphere::curve::bspline::Deg;
    use crate::sphere::geometry::point::{Fixed, PointSet};

    /// A wavy line of 40 points and the polyline through 4 of them, its second vertex then
    /// moved off the line (as a refit's step moves it).
    fn moved_polyline(points: &PointSet) -> Fitter<'_, Fixed<3>, Deg<1>> {
        let n = points.len();
        let params: Vec<f64> = (0..n).map(|j| j as f64 / (n - 1) as f64).collect();
        let kept = [0, 13, 26, n - 1];
        let knots = vec![0.0, 0.0, params[13], params[26], 1.0, 1.0];
        let ctrl = points.subset(&kept);
        let mut f =
            Fitter::unmeasured(Fixed::<3>, Deg::<1>, points, true, params, knots, ctrl).measured();
        let v = f.ctrl.get_mut(1);
        v[2] += 2e-3;
        let norm = v.iter().map(|x| x * x).sum::<f64>().sqrt();
        v.iter_mut().for_each(|x| *x /= norm);
        f
    }

    fn wavy_line() -> PointSet {
        super::super::test_wave(40, 0.003, 0.004, 9.0, |_| 0.0)
    }

    #[test]
    fn one_projection_pass_measures_at_foot_points_no_farther_than_measure_then_correct() {
        let points = wavy_line();
        let n = points.len();
        // Measured at the old parameters, then corrected (the two passes it replaces).
        let mut two = moved_polyline(&points);
        two.measure_range(0, n);
        two.correct_range(0, n, 1);
        // One pass.
        let mut one = moved_polyline(&points);
        let old = one.params.clone();
        let (max, sq) = one.project_range_polyline(0, n);
        assert!(one.params.windows(2).all(|w| w[0] <= w[1]));
        let mut moved = 0;
        for j in 0..n {
            // Its errors are the curve's distances at its parameters ...
            let e = one.err[j];
            let at = one.error_at(j, one.params[j]);
            assert!((e - at).abs() < 1e-12, "point {j}: {e} vs {at}");
            // ... never farther than at the old parameter, nor than measure-then-correct.
            assert!(e <= one.error_at(j, old[j]) + 1e-15, "point {j}");
            assert!(e <= two.err[j] + 1e-12, "point {j}: {e} vs {}", two.err[j]);
            moved += usize::from(one.params[j] != old[j]);
        }
        assert!(
            moved > n / 2,
            "only {moved} of {n} moved to their foot points"
        );
        let max_err = one.err.iter().fold(0.0f64, |a, &b| a.max(b));
        let sum_sq: f64 = one.err.iter().map(|e| e * e).sum();
        assert_eq!(max, max_err);
        assert!((sq - sum_sq).abs() <= 1e-15 * sum_sq.max(1e-300));
    }
}
