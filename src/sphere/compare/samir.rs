//! Samir et al.'s gradient descent (C. Samir, P.-A. Absil, A. Srivastava & E. Klassen,
//! "A gradient-descent method for curve fitting on Riemannian manifolds", Foundations of
//! Computational Mathematics 12, 2012, pp. 49–73; the GLS-PIA paper's \[SASK12\]).
//!
//! The curve γ is discretised at `M` nodes `γ_k = γ(s_k)`, `s_k = k / (M − 1)`, and joined by
//! great-circle arcs. It minimises
//!
//! `E(γ) = ½ Σ_i d²(γ(t_i), p_i) + (λ/2) Σ_{k=1}^{M−2} h ‖a_k‖²`,
//! `a_k = (log_{γ_k} γ_{k+1} + log_{γ_k} γ_{k−1}) / h²`, `h = 1 / (M − 1)`,
//!
//! the paper's `½ Σ d² + (λ/2) ∫ ‖D²γ/dt²‖²` with the covariant second derivative replaced by
//! its central difference, `γ(t_i)` the arc between the two nodes around `t_i`.
//!
//! Each step computes the differential of `E` at every node (as a tangent vector), turns it
//! into the gradient of the **second-order Palais metric**
//! `⟨⟨v, w⟩⟩ = ⟨v(0), w(0)⟩ + ⟨Dv(0), Dw(0)⟩ + ∫ ⟨D²v, D²w⟩ dt` (the paper's §4.2) by solving
//! the metric's Gram system, and moves every node along its geodesic: `γ_k ← exp_{γ_k}(−α G_k)`,
//! α by Armijo backtracking (sufficient decrease 1e-4, halving, the next trial doubling the
//! last accepted step).
//!
//! Choices the paper leaves open, made here:
//! * Vector fields along the curve are compared in a frame carried by **parallel transport**
//!   along the discrete curve, so covariant derivatives become differences of coordinates
//!   and the Palais Gram matrix is one pentadiagonal matrix shared by all coordinates
//!   (solved by band Cholesky, O(M)).
//! * The differential of the penalty is taken in the same coordinates, from the Euler–Lagrange
//!   operator of `½∫‖D²γ‖²` on S^n: `D⁴γ + R(D²γ, γ')γ'` with
//!   `R(a, v)v = ‖v‖² a − ⟨a, v⟩ v` (unit sphere), `D⁴` as the second difference of `a`.
//!   The data term's differential is exact (`−log_{γ(t_i)} p_i`, shared by the two nodes
//!   around `t_i` by their linear weights). The energy the line search tests is the exact
//!   discrete `E`, so a step is accepted only when it lowers `E`.
//! * Nodes: one per data point by default (the curve at the data's resolution), at most
//!   [`MAX_NODES`], evenly spaced in parameter; the initial curve is the data polyline at the
//!   nodes.
//! * λ: [`super::DEFAULT_LAMBDA`] unless given (the paper fixes none).
//! * Stopping: when a step lowers `E` by less than 1e-9 of itself or no step length lowers
//!   it (converged), after [`MethodOptions::iterations`] steps (default 100,000), or at the
//!   time budget: the GLS-PIA paper stopped it at the wall time of 30 GLS-PIA iterations.

use crate::sphere::compare::frame::{develop, transport_vector, Walk};
use crate::sphere::compare::{polyline_at, Clock, CompareError, Fitted, MethodOptions};
use crate::sphere::geometry::point::{angle, exp_in_place, log_into, Arc, Dynamic, PointSet};
use crate::sphere::linalg::banded::SymmetricBand;

/// Most nodes of the discretised curve: the Palais metric's Gram matrix has condition number
/// of order `(M − 1)⁴`, and at 10⁵ nodes its band Cholesky factorisation fails in double
/// precision (measured); 10⁴ nodes factorise.
pub const MAX_NODES: usize = 10_000;

/// Gradient steps when [`MethodOptions::iterations`] is not given.
pub const DEFAULT_STEPS: usize = 100_000;

/// A step lowering `E` by less than this fraction of itself ends the descent.
pub const STAGNATION: f64 = 1e-9;

/// Armijo's sufficient-decrease constant.
const ARMIJO: f64 = 1e-4;

/// The discretised problem: node parameters and, for each data point, its segment and the
/// fraction along it.
struct Problem<'a> {
    points: &'a PointSet,
    seg: Vec<usize>,
    frac: Vec<f64>,
    m: usize,
    h: f64,
    lambda: f64,
}

impl Problem<'_> {
    /// The curve at data point `i`'s parameter.
    fn at_data(&self, nodes: &PointSet, i: usize, out: &mut [f64]) {
        let d = Dynamic(nodes.dim());
        let k = self.seg[i];
        let (a, b) = (nodes.get(k), nodes.get(k + 1));
        let (w0, w1) = Arc::between(d, a, b).weights(self.frac[i]);
        for c in 0..out.len() {
            out[c] = w0 * a[c] + w1 * b[c];
        }
        crate::sphere::geometry::point::normalize(d, out);
    }

    /// The discrete energy `E`.
    fn energy(&self, nodes: &PointSet) -> f64 {
        let dim = nodes.dim();
        let d = Dynamic(dim);
        let mut c = vec![0.0; dim];
        let mut data = 0.0;
        for i in 0..self.points.len() {
            self.at_data(nodes, i, &mut c);
            let e = angle(d, &c, self.points.get(i));
            data += e * e;
        }
        let (mut fwd, mut back) = (vec![0.0; dim], vec![0.0; dim]);
        let mut pen = 0.0;
        let h2 = self.h * self.h;
        for k in 1..self.m - 1 {
            log_into(d, nodes.get(k), nodes.get(k + 1), &mut fwd);
            log_into(d, nodes.get(k), nodes.get(k - 1), &mut back);
            pen += fwd
                .iter()
                .zip(&back)
                .map(|(f, b)| ((f + b) / h2).powi(2))
                .sum::<f64>();
        }
        0.5 * data + 0.5 * self.lambda * self.h * pen
    }

    /// The differential of `E` at each node, in the coordinates of the transported frame
    /// (n per node).
    fn differential(&self, nodes: &PointSet) -> Vec<f64> {
        let dim = nodes.dim();
        let n = dim - 1;
        let d = Dynamic(dim);
        let m = self.m;
        let mut g = vec![0.0; m * n];
        // Data term.
        let mut walk = Walk::new(nodes);
        let (mut c, mut r, mut local) = (vec![0.0; dim], vec![0.0; dim], vec![0.0; n]);
        for i in 0..self.points.len() {
            let k = self.seg[i];
            walk.advance_to(k);
            self.at_data(nodes, i, &mut c);
            log_into(d, &c, self.points.get(i), &mut r);
            // Back to node k along the arc, then into its frame.
            transport_vector(&c, nodes.get(k), 1.0, &mut r);
            walk.frame().coords(&r, &mut local);
            let s = self.frac[i];
            for j in 0..n {
                g[k * n + j] -= (1.0 - s) * local[j];
                g[(k + 1) * n + j] -= s * local[j];
            }
        }
        // Penalty: λ h (D⁴γ + R(D²γ, γ')γ') in developed coordinates.
        if self.lambda > 0.0 {
            let x = develop(nodes);
            let h = self.h;
            let mut a = vec![0.0; m * n];
            for k in 1..m - 1 {
                for j in 0..n {
                    a[k * n + j] =
                        (x[(k + 1) * n + j] - 2.0 * x[k * n + j] + x[(k - 1) * n + j]) / (h * h);
                }
            }
            let lh = self.lambda * h;
            for k in 0..m {
                for j in 0..n {
                    let prev = if k >= 1 { a[(k - 1) * n + j] } else { 0.0 };
                    let next = if k + 1 < m { a[(k + 1) * n + j] } else { 0.0 };
                    g[k * n + j] += lh * (prev - 2.0 * a[k * n + j] + next) / (h * h);
                }
                if k >= 1 && k + 1 < m {
                    let v: Vec<f64> = (0..n)
                        .map(|j| (x[(k + 1) * n + j] - x[(k - 1) * n + j]) / (2.0 * h))
                        .collect();
                    let ak = &a[k * n..(k + 1) * n];
                    let vv: f64 = v.iter().map(|z| z * z).sum();
                    let av: f64 = ak.iter().zip(&v).map(|(p, q)| p * q).sum();
                    for j in 0..n {
                        g[k * n + j] += lh * (vv * ak[j] - av * v[j]);
                    }
                }
            }
        }
        g
    }
}

/// The Gram matrix of the discrete second-order Palais metric on `m` nodes `h` apart:
/// `e₀e₀ᵀ + d₁d₁ᵀ + h Σ_k w_k w_kᵀ`, `d₁ = (e₁ − e₀)/h`, `w_k = (e_{k+1} − 2e_k + e_{k−1})/h²`.
fn palais_gram(m: usize, h: f64) -> SymmetricBand {
    let mut g = SymmetricBand::zeros(m, 2);
    g.add_upper(0, 0, 1.0);
    let d1 = 1.0 / (h * h);
    g.add_upper(0, 0, d1);
    g.add_upper(1, 1, d1);
    g.add_upper(0, 1, -d1);
    let w = h / (h * h * h * h);
    let coef = [1.0, -2.0, 1.0];
    for k in 1..m - 1 {
        let idx = [k - 1, k, k + 1];
        for a in 0..3 {
            for b in a..3 {
                g.add_upper(idx[a], idx[b], w * coef[a] * coef[b]);
            }
        }
    }
    g
}

/// Fits `points` at `params` and samples the curve at `ts`.
pub(crate) fn fit(
    points: &PointSet,
    params: &[f64],
    options: &MethodOptions,
    ts: &[f64],
) -> Result<Fitted, CompareError> {
    let m = options
        .nodes
        .unwrap_or_else(|| points.len().min(MAX_NODES))
        .max(3);
    let dim = points.dim();
    let n = dim - 1;
    let d = Dynamic(dim);
    let h = 1.0 / (m - 1) as f64;
    let node_params: Vec<f64> = (0..m).map(|k| k as f64 * h).collect();
    let (seg, frac): (Vec<usize>, Vec<f64>) = params
        .iter()
        .map(|&t| {
            let k = ((t / h).floor() as usize).min(m - 2);
            (k, ((t - node_params[k]) / h).clamp(0.0, 1.0))
        })
        .unzip();
    let problem = Problem {
        points,
        seg,
        frac,
        m,
        h,
        lambda: options.lambda,
    };
    let chol = palais_gram(m, h)
        .cholesky(0.0, 0.0)
        .ok_or_else(|| CompareError::Singular {
            method: "samir",
            reason: "the Palais metric's Gram matrix is not positive definite".into(),
        })?;
    let mut nodes = polyline_at(points, params, &node_params);
    let mut energy = problem.energy(&nodes);
    let clock = Clock::start(options.time_budget);
    let steps = options.iterations.unwrap_or(DEFAULT_STEPS);
    let mut alpha: f64 = 1.0;
    let mut done = 0;
    let mut converged = false;
    let mut dir = vec![0.0; m * dim];
    let mut local = vec![0.0; dim];
    while done < steps {
        options.gls_pia.cancel.check()?;
        let g = problem.differential(&nodes);
        let mut grad = g.clone();
        chol.solve_in_place(&mut grad, n);
        let slope: f64 = g.iter().zip(&grad).map(|(a, b)| a * b).sum();
        if !(slope.is_finite() && slope > 0.0) {
            converged = true;
            break;
        }
        // Ambient directions at the nodes.
        let mut walk = Walk::new(&nodes);
        for k in 0..m {
            walk.advance_to(k);
            walk.frame().vector(&grad[k * n..(k + 1) * n], &mut local);
            dir[k * dim..(k + 1) * dim].copy_from_slice(&local);
        }
        let mut accepted = None;
        let mut trial = (alpha * 2.0).min(1e300);
        for _ in 0..200 {
            let mut moved = nodes.clone();
            let mut step = vec![0.0; dim];
            for k in 0..m {
                for c in 0..dim {
                    step[c] = -trial * dir[k * dim + c];
                }
                exp_in_place(d, moved.get_mut(k), &step);
            }
            let e = problem.energy(&moved);
            if e <= energy - ARMIJO * trial * slope {
                accepted = Some((moved, e));
                break;
            }
            trial *= 0.5;
            if trial < 1e-300 {
                break;
            }
        }
        let Some((moved, e)) = accepted else {
            converged = true;
            break;
        };
        let drop = energy - e;
        nodes = moved;
        alpha = trial;
        done += 1;
        let stagnated = drop <= STAGNATION * energy;
        energy = e;
        if stagnated {
            converged = true;
            break;
        }
        if clock.spent() {
            break;
        }
    }
    let mut fitted = vec![0.0; points.len() * dim];
    for (i, out) in fitted.chunks_exact_mut(dim).enumerate() {
        problem.at_data(&nodes, i, out);
    }
    Ok(Fitted {
        fitted: PointSet::from_flat_unchecked(dim, fitted),
        samples: polyline_at(&nodes, &node_params, ts),
        iterations: done,
        converged,
        free_points: m,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_palais_gram_matrix_measures_constant_and_linear_fields_as_the_metric_does() {
        let m = 12;
        let h = 1.0 / 11.0;
        let g = palais_gram(m, h);
        assert!(g.cholesky(0.0, 0.0).is_some(), "positive definite");
        let norm2 = |v: &[f64]| -> f64 {
            (0..m)
                .flat_map(|i| (0..m).map(move |j| (i, j)))
                .filter(|&(i, j)| i.abs_diff(j) <= 2)
                .map(|(i, j)| v[i] * g.get(i, j) * v[j])
                .sum()
        };
        // Constant field: only |v(0)|² = 1. Linear field v(s) = s: only |Dv(0)|² = 1.
        assert!((norm2(&[1.0; 12]) - 1.0).abs() < 1e-9);
        let linear: Vec<f64> = (0..m).map(|k| k as f64 * h).collect();
        assert!((norm2(&linear) - 1.0).abs() < 1e-9);
        // A quadratic v(s) = s²: |v(0)|² + |Dv(0)|² + ∫ 4 = 0 + h² + 4(1 − h) (the discrete
        // second differences at the interior nodes).
        let quad: Vec<f64> = (0..m).map(|k| (k as f64 * h).powi(2)).collect();
        assert!((norm2(&quad) - (h * h + 4.0 * (1.0 - h))).abs() < 1e-9);
    }
}
