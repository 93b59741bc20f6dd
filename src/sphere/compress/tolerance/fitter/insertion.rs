//! Knot insertion where points are out of tolerance, with refits until the target is met.

use super::{Fitter, REFIT_ITERATIONS};
use crate::sphere::curve::bspline::Degree;
use crate::sphere::geometry::point::{slerp, Dim, PointSet};

/// The best state seen while refining: (max error, knots, control points, parameters, errors).
type Snapshot = (f64, Vec<f64>, PointSet, Vec<f64>, Vec<f64>);

impl<D: Dim, G: Degree> Fitter<'_, D, G> {
    /// Inserts knots where points are out of tolerance (at the worst point's parameter, or the
    /// span's middle when that is too close to a knot) and refits, until the target is met, the
    /// cap is reached or nothing can be inserted.
    pub(in crate::sphere::compress::tolerance) fn refine(&mut self, target: f64, cap: usize) {
        let mut best: Option<Snapshot> = None;
        loop {
            let n = self.n_ctrl();
            let max = self.refit(0, n, REFIT_ITERATIONS, target);
            let max = max.max(self.max_error());
            if best.as_ref().is_none_or(|b| max < b.0) {
                best = Some((
                    max,
                    self.knots.clone(),
                    self.ctrl.clone(),
                    self.params.clone(),
                    self.err.clone(),
                ));
            }
            if max <= target || n >= cap || crate::sphere::cancel::cancelled() {
                break;
            }
            // Worst out-of-tolerance point per span.
            let frame_last = self.last_span();
            let p = self.p();
            let mut worst: Vec<(usize, usize, f64)> = Vec::new(); // (span, j, err)
            for j in 0..self.points.len() {
                if self.err[j] <= target {
                    continue;
                }
                let t = self.params[j];
                let k = (self.knots.partition_point(|&u| u <= t).saturating_sub(1))
                    .clamp(p, frame_last);
                match worst.last_mut() {
                    Some(w) if w.0 == k => {
                        if self.err[j] > w.2 {
                            *w = (k, j, self.err[j]);
                        }
                    }
                    _ => worst.push((k, j, self.err[j])),
                }
            }
            let mut inserted = 0;
            for &(k, j, _) in worst.iter().rev() {
                if self.n_ctrl() >= cap {
                    break;
                }
                let (a, b) = (self.knots[k], self.knots[k + 1]);
                let w = b - a;
                if w <= 1e-12 {
                    continue;
                }
                let t = self.params[j];
                let u = if t - a > 0.1 * w && b - t > 0.1 * w {
                    t
                } else {
                    0.5 * (a + b)
                };
                self.insert_knot(k, u);
                inserted += 1;
            }
            if inserted == 0 {
                break;
            }
        }
        if let Some((max, knots, ctrl, params, err)) = best {
            if max < self.max_error() {
                self.knots = knots;
                self.ctrl = ctrl;
                self.params = params;
                self.err = err;
            }
        }
    }

    /// Boehm's knot insertion with SLERP in place of the affine combinations: `u` in span k.
    fn insert_knot(&mut self, k: usize, u: f64) {
        let (p, dim) = (self.p(), self.d.get());
        let n = self.n_ctrl();
        let old = self.ctrl.as_flat();
        let mut coords = Vec::with_capacity((n + 1) * dim);
        coords.extend_from_slice(&old[..(k + 1 - p) * dim]);
        for i in k + 1 - p..=k {
            let den = self.knots[i + p] - self.knots[i];
            let alpha = if den > 0.0 {
                ((u - self.knots[i]) / den).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let (a, b) = (self.ctrl.get(i - 1), self.ctrl.get(i));
            match slerp(a, b, alpha) {
                Ok(v) => coords.extend_from_slice(&v),
                Err(_) => coords.extend_from_slice(b),
            }
        }
        coords.extend_from_slice(&old[k * dim..]);
        self.ctrl = PointSet::from_flat_unchecked(dim, coords);
        self.knots.insert(k + 1, u);
    }
}
