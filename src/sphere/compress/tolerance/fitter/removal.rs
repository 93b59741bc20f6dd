//! Greedy knot removal with local refits and Lawson reweighting.

use crate::sphere::compress::tolerance::fitter::refit::Stale;
use crate::sphere::compress::tolerance::fitter::Fitter;
use crate::sphere::curve::bspline::Degree;
use crate::sphere::geometry::arc::{distance_key, distance_to_arc, ArcFrame};
use crate::sphere::geometry::point::Dim;

/// Gauss–Newton passes of a removal's refit (and of each reweighted refit). A removal that
/// two passes do not make meet the tolerance is left for a later sweep or kept out: on the
/// Natural Earth 10m land outlines (2 threads, user time, 2026-12-05) 2 passes against the 6 of
/// other refits cut the fit's CPU by 14 % at 100 m, 30 % at 1 km and 35 % at 5 km, for
/// +0.3 %, -0.4 % and +0.3 % stored numbers (1 pass: +1.3 % and more time at 5 km, where more
/// pieces missed their two-way check and were refitted).
const REMOVAL_ITERATIONS: usize = 2;

/// Lawson reweighting rounds when a removal misses the tolerance by less than
/// [`REWEIGHT_WITHIN`] times.
const REWEIGHT_ROUNDS: usize = 2;

/// See [`REWEIGHT_ROUNDS`].
const REWEIGHT_WITHIN: f64 = 1.5;

/// A second reweighting round is tried only when the first left the window within this many
/// targets: from farther out it seldom ends within the target (10m land outlines at 1 km: 74
/// of 4,268 such rounds did), and the rounds are two fifths of a removal's Gauss–Newton steps.
/// On the whole file (callgrind, 1 thread, 2026-12-06): 1.3 % fewer instructions at 1 km and
/// 1.7 % at 5 km, for 64 and 16 more stored numbers (0.03 % and 0.02 %).
const REWEIGHT_AGAIN_WITHIN: f64 = 1.2;

/// Extra control points freed on each side of a removed knot's p + 1 affected ones.
const REMOVAL_MARGIN: usize = 1;

/// A polyline (degree 1) with this many points per span or more on average when its removals
/// start is refitted without the [`REMOVAL_MARGIN`]: its spans are long against the point
/// spacing (a coarse tolerance), so each refit window holds many points and the margin's two
/// extra spans cost most of the refit.
const COARSE_POINTS_PER_SPAN: usize = 4;

/// See [`Fitter::hopeless_removal`]: a point this many targets from the chord that would
/// replace a removed vertex's two segments is not brought back by the window's refit.
const HOPELESS_REMOVAL: f64 = 2.0;

/// Removal sweeps over all knots (each sweep stops early when nothing could be removed).
const REMOVAL_SWEEPS: usize = 3;

/// A polyline with free parameters and this many points per span or more on average when its
/// removals start moves the points of the span that replaces a removed vertex's two to their
/// feet on it before the refit, instead of measuring them at their old parameters (which
/// fall along the new span where the old spans put them, far from their feet when the two
/// spans differed in length). The refit then starts from the errors it would reach by its
/// first foot-point pass, and fewer removals fail on a first step spent on the parameters.
/// On the 10m land outlines (callgrind, 1 thread, 2026-12-06): 0.29 % fewer stored numbers
/// at 1 km and 0.32 % at 5 km for 0.6 % more instructions; at 100 m, where most rings have
/// fewer points per span, on every ring it took 0.9 % more instructions for 90 more numbers,
/// hence the threshold (with it: +6 numbers, +0.2 %).
const FEET_FIRST_POINTS_PER_SPAN: usize = 2;

impl<D: Dim, G: Degree> Fitter<'_, D, G> {
    /// Greedy knot removal: each interior knot in turn is removed, the p + 1 + 2·margin control
    /// points around it refitted, and the removal kept when the tolerance still holds.
    ///
    /// A removal that failed is tried again in a later sweep only when a removal since then
    /// changed what it reads (the control points, parameters and errors within reach of its
    /// window): the refit is deterministic, so an unchanged neighbourhood fails again. This
    /// skips most of the second and third sweeps without changing the result.
    pub(in crate::sphere::compress::tolerance) fn reduce(&mut self, target: f64) {
        let p = self.p();
        let margin = if p == 1 && self.points.len() >= COARSE_POINTS_PER_SPAN * self.n_ctrl() {
            0
        } else {
            REMOVAL_MARGIN
        };
        let feet_first =
            p == 1 && self.free && self.points.len() >= FEET_FIRST_POINTS_PER_SPAN * self.n_ctrl();
        // Per knot: its removal failed and nothing within its reach changed since.
        let mut clean = vec![false; self.knots.len()];
        for _ in 0..REMOVAL_SWEEPS {
            let mut removed = 0;
            let mut r = p + 1;
            while r < self.n_ctrl() && !crate::sphere::cancel::cancelled() {
                if clean[r] {
                    r += 1;
                } else if let Some((c0, c1)) = self.try_remove(r, target, margin, feet_first) {
                    removed += 1;
                    clean.remove(r);
                    // Windows that read control points c0 .. c1 (or their points) belong to
                    // knots from about c0 − p − margin to c1 + 2p + margin.
                    let lo = c0.saturating_sub(p + margin + 2);
                    let hi = (c1 + 2 * p + margin + 3).min(clean.len());
                    clean[lo..hi].iter_mut().for_each(|c| *c = false);
                } else {
                    clean[r] = true;
                    r += 1;
                }
            }
            if removed == 0 {
                break;
            }
        }
    }

    /// Tries to remove knot `r`: the refitted window of control points when kept. With
    /// `feet_first` (a polyline with free parameters, see [`FEET_FIRST_POINTS_PER_SPAN`]) the
    /// points of the replacing span are moved to their feet on it before the refit.
    fn try_remove(
        &mut self,
        r: usize,
        target: f64,
        margin: usize,
        feet_first: bool,
    ) -> Option<(usize, usize)> {
        let (p, dim) = (self.p(), self.d.get());
        let n = self.n_ctrl();
        if n <= p + 1 {
            return None;
        }
        let c = r - p.div_ceil(2);
        if p == 1 && self.hopeless_removal(c, target) {
            return None;
        }
        // A polyline's curve changes only on the span that replaces the removed vertex's two
        // (from knot c to knot c + 2, its ends included): the rest of the window keeps its
        // errors, and only that span's points are measured before the refit.
        let stale = if p == 1 {
            let (lo, hi) = (self.knots[c], self.knots[c + 2]);
            Stale::Points(
                self.params.partition_point(|&t| t < lo),
                self.params.partition_point(|&t| t <= hi),
            )
        } else {
            Stale::Window
        };
        // Only the window changes: it alone is saved, and the removal is undone in place.
        let mut undo = std::mem::take(&mut self.undo);
        let knot_removed = self.knots.remove(r);
        undo.removed.clear();
        undo.removed.extend_from_slice(self.ctrl.get(c));
        self.ctrl.remove(c);
        let n = n - 1;
        let c0 = (r + 1).saturating_sub(p + 2 + margin);
        let c1 = (r + margin).min(n);
        undo.ctrl.clear();
        undo.ctrl
            .extend_from_slice(&self.ctrl.as_flat()[c0 * dim..c1 * dim]);
        let (j0, j1) = self.window_points(c0, c1);
        undo.params.clear();
        undo.params.extend_from_slice(&self.params[j0..j1]);
        undo.err.clear();
        undo.err.extend_from_slice(&self.err[j0..j1]);
        let stale = match stale {
            Stale::Points(s0, s1) if feet_first => {
                // Measured at their feet instead: nothing else in the window changed.
                self.project_range_polyline(s0.clamp(j0, j1), s1.clamp(j0, j1));
                Stale::Points(j0, j0)
            }
            stale => stale,
        };
        let mut max = self.refit_from(c0, c1, REMOVAL_ITERATIONS, target, 4.0, false, stale);
        if self.reweight {
            let mut round = 0;
            loop {
                let within = if round == 0 {
                    REWEIGHT_WITHIN
                } else {
                    REWEIGHT_AGAIN_WITHIN
                };
                if max <= target || max > within * target || round >= REWEIGHT_ROUNDS {
                    break;
                }
                for j in j0..j1 {
                    let r = self.err[j] / target;
                    self.weight[j] *= 1.0 + r * r * r * r;
                }
                // Reweighting changes no error: none is measured again.
                let none = Stale::Points(j0, j0);
                max = self.refit_from(
                    c0,
                    c1,
                    REMOVAL_ITERATIONS,
                    target,
                    f64::INFINITY,
                    false,
                    none,
                );
                round += 1;
            }
            self.weight[j0..j1].iter_mut().for_each(|w| *w = 1.0);
        }
        let kept = max <= target && self.vertices_near_the_line(c0, c1, target);
        if !kept {
            self.restore(c0, &undo.ctrl);
            self.ctrl.insert(c, &undo.removed);
            self.knots.insert(r, knot_removed);
            self.params[j0..j1].copy_from_slice(&undo.params);
            self.err[j0..j1].copy_from_slice(&undo.err);
        }
        self.undo = undo;
        kept.then_some((c0, c1))
    }

    /// For a polyline (degree 1): removing vertex `c` replaces its two segments by the chord
    /// between its neighbours; when a data point of those segments lies farther than
    /// [`HOPELESS_REMOVAL`] times the target from that chord, the local refit (which moves the
    /// neighbours a little) cannot bring it back, and trying costs a Gauss–Newton refit.
    fn hopeless_removal(&self, c: usize, target: f64) -> bool {
        let n = self.n_ctrl();
        if c == 0 || c + 1 >= n {
            return false;
        }
        // Degree 1: control point i sits at knot i + 1; the two spans around c run from
        // knot c to knot c + 2.
        let (lo, hi) = (self.knots[c], self.knots[c + 2]);
        let j0 = self.params.partition_point(|&t| t < lo);
        let j1 = self.params.partition_point(|&t| t <= hi);
        let chord = ArcFrame::new(self.d, self.ctrl.get(c - 1), self.ctrl.get(c + 1));
        let limit = HOPELESS_REMOVAL * target;
        if chord.is_antipodal() {
            return (j0..j1).any(|j| chord.distance_dyn(self.points.get(j)) > limit);
        }
        // Compared by their keys: no square root or arcsine per point.
        let key = distance_key(limit);
        (j0..j1).any(|j| chord.distance_key(self.d, self.points.get(j)) > key)
    }

    /// For a polyline (degree 1), whether control points `c0 .. c1` lie within `target` of the
    /// input segment at their parameter. The vertex errors bound the input's vertices against
    /// the curve; the curve's own corners are what can stray from the input between them (a
    /// removal that cuts across a fjord whose points all stay near the new chord, in order),
    /// and such a curve would fail the two-way check later, after all the work. Higher degrees
    /// are left to that check.
    fn vertices_near_the_line(&self, c0: usize, c1: usize, target: f64) -> bool {
        if self.p() != 1 {
            return true;
        }
        let n = self.points.len();
        (c0.max(1)..c1.min(self.n_ctrl() - 1)).all(|i| {
            let u = self.knots[i + 1];
            let j = self.params.partition_point(|&t| t <= u).clamp(1, n - 1) - 1;
            let v = self.ctrl.get(i);
            let d = distance_to_arc(v, self.points.get(j), self.points.get(j + 1));
            // At a data parameter exactly, either neighbouring segment will do.
            d <= target
                || (j > 0
                    && self.params[j] == u
                    && distance_to_arc(v, self.points.get(j - 1), self.points.get(j)) <= target)
        })
    }
}

#[cfg(test)]
mod tests {
    use crate::sphere::compress::tolerance::fitter::{test_wave, Fitter};
    use crate::sphere::compress::tolerance::{Line, ToleranceOptions};
    use crate::sphere::curve::bspline::Deg;
    use crate::sphere::fit::knots::{parameters, Parameterization};
    use crate::sphere::geometry::point::Fixed;

    #[test]
    fn errors_stay_current_through_removals_so_refits_measure_only_what_changed() {
        // A jittery wave: removals kept and undone, reweighted refits, corners. The refits
        // after a removal measure only the span that replaced the vertex's two, and the
        // reweighted ones measure nothing: that is only right while `err` holds every
        // point's error on the current curve, which a fresh measurement checks here.
        let jitter = |i: usize| 2e-5 * ((i * 7919) % 13) as f64 / 13.0;
        let points = test_wave(600, 0.0005, 0.004, 40.0, jitter);
        let params = parameters(&points, Parameterization::Chord).unwrap();
        let line = Line {
            points: &points,
            params: &params,
            free: true,
        };
        for (target, pin_ends) in [(3e-5, false), (1e-4, false), (4e-4, false), (1e-4, true)] {
            let options = ToleranceOptions {
                pin_ends,
                ..ToleranceOptions::default()
            };
            let mut f =
                Fitter::seeded(Fixed::<3>, Deg::<1>, line, target, 600, &options).expect("a seed");
            f.reweight = true;
            f.refine(target, 600);
            let seeded = f.n_ctrl();
            f.reduce(target);
            assert!(f.n_ctrl() < seeded, "nothing removed at {target}");
            let kept = f.err.clone();
            f.measure_range(0, points.len());
            for (j, (a, b)) in kept.iter().zip(&f.err).enumerate() {
                assert!(
                    (a - b).abs() <= 1e-12 * target,
                    "point {j}: {a} kept, {b} measured"
                );
            }
            assert!(f.max_error() <= target);
        }
    }
}
