//! Symmetric positive definite band matrices and their Cholesky factorisation, for the normal
//! equations of least-squares spline fits: each data point touches p + 1 consecutive control
//! points, so `AᵀA` has half-bandwidth p and factorises in O(N p²).

/// A symmetric N x N matrix with half-bandwidth `bw`, upper band stored row by row:
/// `get(i, i + d)` for d = 0..=bw.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SymmetricBand {
    n: usize,
    bw: usize,
    data: Vec<f64>,
}

impl SymmetricBand {
    /// The zero matrix.
    pub fn zeros(n: usize, bw: usize) -> SymmetricBand {
        SymmetricBand {
            n,
            bw,
            data: vec![0.0; n * (bw + 1)],
        }
    }

    /// Makes this the n x n zero matrix of half-bandwidth `bw`, reusing its storage (a fitter
    /// solves thousands of small windows).
    pub fn reset(&mut self, n: usize, bw: usize) {
        self.n = n;
        self.bw = bw;
        self.data.clear();
        self.data.resize(n * (bw + 1), 0.0);
    }

    /// Element (i, j) with |i - j| <= bw.
    #[inline(always)]
    pub fn get(&self, i: usize, j: usize) -> f64 {
        let (i, j) = if i <= j { (i, j) } else { (j, i) };
        self.data[i * (self.bw + 1) + (j - i)]
    }

    /// Adds `v` to element (i, j) (and, by symmetry, (j, i)); `i <= j <= i + bw`.
    #[inline(always)]
    pub fn add_upper(&mut self, i: usize, j: usize, v: f64) {
        self.data[i * (self.bw + 1) + (j - i)] += v;
    }

    /// Adds another band matrix of the same bandwidth whose row 0 is row `offset` here.
    pub fn add_block(&mut self, offset: usize, other: &SymmetricBand) {
        debug_assert_eq!(self.bw, other.bw);
        let w = self.bw + 1;
        for (k, v) in other.data.iter().enumerate() {
            let (i, d) = (k / w, k % w);
            if offset + i + d < self.n {
                self.data[(offset + i) * w + d] += v;
            }
        }
    }

    /// Largest diagonal element.
    pub fn max_diagonal(&self) -> f64 {
        (0..self.n).map(|i| self.get(i, i)).fold(0.0, f64::max)
    }

    /// Cholesky factor of `self + diag(shift_i)`, with `shift_i = damping * a_ii + ridge`.
    /// `None` when the shifted matrix is not positive definite.
    pub fn cholesky(&self, damping: f64, ridge: f64) -> Option<BandCholesky> {
        let mut out = BandCholesky::default();
        self.cholesky_into(damping, ridge, &mut out).then_some(out)
    }

    /// [`cholesky`](Self::cholesky) into `out`, reusing its storage; false when the shifted
    /// matrix is not positive definite (`out` is then undefined).
    pub fn cholesky_into(&self, damping: f64, ridge: f64, out: &mut BandCholesky) -> bool {
        let (n, bw) = (self.n, self.bw);
        let w = bw + 1;
        out.n = n;
        out.bw = bw;
        // l[i * w + d] = L[i][i - d].
        let l = &mut out.l;
        l.clear();
        l.resize(n * w, 0.0);
        for i in 0..n {
            let lo = i.saturating_sub(bw);
            for j in lo..=i {
                let mut s = self.get(j, i);
                if i == j {
                    s += damping * s + ridge;
                }
                for k in lo.max(j.saturating_sub(bw))..j {
                    s -= l[i * w + (i - k)] * l[j * w + (j - k)];
                }
                if i == j {
                    if s <= 0.0 || !s.is_finite() {
                        return false;
                    }
                    l[i * w] = s.sqrt();
                } else {
                    l[i * w + (i - j)] = s / l[j * w];
                }
            }
        }
        true
    }
}

/// The lower band Cholesky factor L of a [`SymmetricBand`].
#[derive(Clone, Debug, Default)]
pub struct BandCholesky {
    n: usize,
    bw: usize,
    l: Vec<f64>,
}

impl BandCholesky {
    /// Solves `L Lᵀ x = b` in place for `cols` right-hand sides stored row-major in `b`
    /// (row i holds the `cols` values of unknown i).
    pub fn solve_in_place(&self, b: &mut [f64], cols: usize) {
        let (n, bw) = (self.n, self.bw);
        let w = bw + 1;
        debug_assert_eq!(b.len(), n * cols);
        // Row i of `b` minus f times row k, then divided by the diagonal.
        let sub_row = |b: &mut [f64], i: usize, k: usize, f: f64| {
            for c in 0..cols {
                b[i * cols + c] -= f * b[k * cols + c];
            }
        };
        let div_row = |b: &mut [f64], i: usize, d: f64| {
            for c in 0..cols {
                b[i * cols + c] /= d;
            }
        };
        for i in 0..n {
            for k in i.saturating_sub(bw)..i {
                sub_row(b, i, k, self.l[i * w + (i - k)]);
            }
            div_row(b, i, self.l[i * w]);
        }
        for i in (0..n).rev() {
            for k in i + 1..(i + bw + 1).min(n) {
                sub_row(b, i, k, self.l[k * w + (k - i)]);
            }
            div_row(b, i, self.l[i * w]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn solves_a_banded_system_exactly() {
        // A tridiagonal-plus matrix with bandwidth 2 and a known solution.
        let n = 9;
        let mut a = SymmetricBand::zeros(n, 2);
        for i in 0..n {
            a.add_upper(i, i, 6.0 + i as f64);
            if i + 1 < n {
                a.add_upper(i, i + 1, -1.5);
            }
            if i + 2 < n {
                a.add_upper(i, i + 2, 0.5);
            }
        }
        let x: Vec<f64> = (0..n * 2).map(|k| (k as f64 * 0.7).sin()).collect();
        let mut b = vec![0.0; n * 2];
        for i in 0..n {
            for j in i.saturating_sub(2)..(i + 3).min(n) {
                for c in 0..2 {
                    b[i * 2 + c] += a.get(i, j) * x[j * 2 + c];
                }
            }
        }
        a.cholesky(0.0, 0.0).unwrap().solve_in_place(&mut b, 2);
        for k in 0..n * 2 {
            assert!((b[k] - x[k]).abs() < 1e-13, "{k}: {} vs {}", b[k], x[k]);
        }
    }

    #[test]
    fn singular_matrices_need_a_ridge() {
        let a = SymmetricBand::zeros(3, 1);
        assert!(a.cholesky(0.0, 0.0).is_none());
        assert!(a.cholesky(0.0, 1e-9).is_some());
    }
}
