//! Gauss–Newton refits (Levenberg–Marquardt damped) of a window of control points.

use crate::sphere::compress::tolerance::fitter::{Fitter, RefitBuffers};
use crate::sphere::curve::bspline::Degree;
use crate::sphere::fit::pass::log_residual;
use crate::sphere::geometry::point::{dot, exp_in_place, Dim};

/// Foot-point Newton steps per point and refit.
const FOOT_POINT_STEPS: usize = 1;

/// See [`Fitter::refit_from`].
const GIVE_UP_AFTER: usize = 3;

impl<D: Dim, G: Degree> Fitter<'_, D, G> {
    /// Gauss–Newton with Levenberg–Marquardt damping on control points `c0 .. c1` (the others
    /// fixed), alternating with foot-point correction; stops once the window's max error is at
    /// or below `target`, or when it stops improving. Returns the window's max error.
    pub(super) fn refit(&mut self, c0: usize, c1: usize, iterations: usize, target: f64) -> f64 {
        self.refit_from(
            c0,
            c1,
            iterations,
            target,
            f64::INFINITY,
            false,
            Stale::Window,
        )
    }

    /// [`refit`](Self::refit) that stops after [`GIVE_UP_AFTER`] iterations when the max error
    /// is still above `give_up × target`: used where a miss is cheap (bisection, removals).
    /// With `stall`, it also stops once even the last pass's gain, kept up for every pass
    /// left, would not reach the target (the passes slow down, they do not speed up): the
    /// long whole-curve fits of the uniform-knot search, where a doomed fit otherwise runs
    /// all its passes. (Not in removals: there the short refits decide which knots go, and
    /// stopping them early changed the greedy order for the worse on the 10m border.)
    /// The window's errors are measured at the start only where `stale` says they are out of
    /// date.
    #[allow(clippy::too_many_arguments)]
    pub(in crate::sphere::compress::tolerance) fn refit_from(
        &mut self,
        c0: usize,
        c1: usize,
        iterations: usize,
        target: f64,
        give_up: f64,
        stall: bool,
        stale: Stale,
    ) -> f64 {
        // A closed line keeps its seam, and pinned ends (junctions of a coverage) stay: the
        // end control points stay on the first and last points, so a ring is closed as
        // fitted and closing it later moves nothing.
        let (c0, c1) = if self.pinned || self.closed() {
            (c0.max(1), c1.min(self.n_ctrl() - 1))
        } else {
            (c0, c1)
        };
        if c0 >= c1 {
            // Nothing free to move (two pinned control points): the window's error as it is.
            let (j0, j1) = self.window_points(0, self.n_ctrl());
            return self.measure_range(j0, j1).0;
        }
        let (j0, j1) = self.window_points(c0, c1);
        if j0 >= j1 {
            return 0.0;
        }
        let (p, dim, d) = (self.p(), self.d.get(), self.d);
        let nf = c1 - c0;
        let (mut max, mut loss) = match stale {
            Stale::Window => self.measure_range(j0, j1),
            Stale::Points(s0, s1) => {
                self.measure_range(s0.clamp(j0, j1), s1.clamp(j0, j1));
                self.window_error(j0, j1)
            }
        };
        let mut lambda = 0.0;
        let mut buffers = std::mem::take(&mut self.buffers);
        buffers.saved.resize(nf * dim, 0.0);
        let mut before = f64::INFINITY;
        // A polyline's step is measured at the foot points it moves the parameters to (one
        // pass, see `project_range_polyline`), and kept when that lowers the loss.
        let fused = self.free && p == 1;
        for it in 0..iterations {
            let stalled = stall
                && it >= GIVE_UP_AFTER
                && max - target > (iterations - it) as f64 * (before - max);
            if max <= target
                || (it >= GIVE_UP_AFTER && max > give_up * target)
                || stalled
                || crate::sphere::cancel::cancelled()
            {
                break;
            }
            before = max;
            let RefitBuffers {
                band,
                chol,
                rhs,
                step,
                saved,
                saved_params,
            } = &mut buffers;
            if fused {
                saved_params.clear();
                saved_params.extend_from_slice(&self.params[j0..j1]);
            }
            band.reset(nf, p);
            rhs.clear();
            rhs.resize(nf * dim, 0.0);
            for j in j0..j1 {
                let t = self.params[j];
                let k = self.eval_into::<true>(t, false);
                let q = self.points.get(j);
                let (_, scale) = log_residual(d, q, &self.c);
                let cos = dot(d, q, &self.c);
                let wj = self.weight[j];
                let coef = &self.eval.scratch.contrib;
                let first = k - p;
                for m in 0..=p {
                    let i = first + m;
                    if i < c0 || i >= c1 {
                        continue;
                    }
                    let w = wj * coef[m];
                    for m2 in m..=p {
                        let i2 = first + m2;
                        if i2 >= c1 {
                            break;
                        }
                        band.add_upper(i - c0, i2 - c0, w * coef[m2]);
                    }
                    let ws = w * scale;
                    let row = &mut rhs[(i - c0) * dim..(i - c0 + 1) * dim];
                    for x in 0..dim {
                        row[x] += ws * (q[x] - cos * self.c[x]);
                    }
                }
            }
            let ridge = 1e-12 * band.max_diagonal().max(f64::MIN_POSITIVE);
            saved.clear();
            saved.extend_from_slice(&self.ctrl.as_flat()[c0 * dim..c1 * dim]);
            let mut accepted = None;
            for _ in 0..8 {
                if !band.cholesky_into(lambda, ridge, chol) {
                    lambda = (lambda * 10.0).max(1e-6);
                    continue;
                }
                step.clear();
                step.extend_from_slice(rhs);
                chol.solve_in_place(step, dim);
                for i in 0..nf {
                    move_along_geodesic(
                        d,
                        self.ctrl.get_mut(c0 + i),
                        &step[i * dim..(i + 1) * dim],
                    );
                }
                let (nmax, nloss) = if fused {
                    self.project_range_polyline(j0, j1)
                } else {
                    self.measure_range(j0, j1)
                };
                if nloss < loss {
                    lambda = if lambda < 1e-9 { 0.0 } else { lambda / 10.0 };
                    accepted = Some((nmax, nloss));
                    break;
                }
                self.restore(c0, saved);
                if fused {
                    self.params[j0..j1].copy_from_slice(saved_params);
                }
                lambda = if lambda == 0.0 { 1e-4 } else { lambda * 10.0 };
            }
            let Some((nmax, nloss)) = accepted else {
                max = self.measure_range(j0, j1).0;
                break;
            };
            let gain = loss - nloss;
            max = nmax;
            loss = nloss;
            // (A polyline's step was measured at its foot points already.)
            if self.free && !fused {
                self.correct_range(j0, j1, FOOT_POINT_STEPS);
                (max, loss) = self.window_error(j0, j1);
            } else if !self.free && gain <= 1e-6 * loss {
                break;
            }
        }
        self.buffers = buffers;
        max
    }

    /// The max error and the weighted sum of squares of points `j0 .. j1`, as they are in
    /// `err` (no point measured).
    fn window_error(&self, j0: usize, j1: usize) -> (f64, f64) {
        (
            self.err[j0..j1].iter().fold(0.0, |a: f64, &b| a.max(b)),
            (j0..j1)
                .map(|j| self.weight[j] * self.err[j] * self.err[j])
                .sum::<f64>(),
        )
    }

    pub(super) fn restore(&mut self, c0: usize, saved: &[f64]) {
        let dim = self.d.get();
        for (i, row) in saved.chunks_exact(dim).enumerate() {
            self.ctrl.get_mut(c0 + i).copy_from_slice(row);
        }
    }
}

/// Which point errors of a refit's window are out of date when it starts (every other one
/// is as `err` holds it: the fitter keeps `err` current through its moves).
#[derive(Clone, Copy)]
pub(in crate::sphere::compress::tolerance) enum Stale {
    /// The whole window: the curve changed under it.
    Window,
    /// Points `s0 .. s1` only (clamped to the window; empty when none is): a polyline's
    /// removal changes the one span that replaces the removed vertex's two, a reweighting
    /// changes no error, and a foot-point correction has just measured every point.
    Points(usize, usize),
}

/// `P ← exp_P(v)` with `v` projected onto the tangent plane at P.
fn move_along_geodesic<D: Dim>(d: D, pt: &mut [f64], v: &[f64]) {
    let along = dot(d, pt, v);
    let mut stack = [0.0; 16];
    let mut heap = Vec::new();
    let t: &mut [f64] = if d.get() <= 16 {
        &mut stack[..d.get()]
    } else {
        heap.resize(d.get(), 0.0);
        &mut heap
    };
    for x in 0..d.get() {
        t[x] = v[x] - along * pt[x];
    }
    exp_in_place(d, pt, t);
}
