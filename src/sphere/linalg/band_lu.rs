//! General band matrices solved by Gaussian elimination with partial pivoting: the Newton
//! step of Beta-spline interpolation, whose block-tridiagonal Jacobian is not symmetric.

/// A banded matrix with `kl` sub- and `ku` super-diagonals and its right-hand side, solved in
/// place by Gaussian elimination with partial pivoting (LAPACK's `gbsv` scheme: pivoting
/// widens the upper band to `kl + ku`). Row `r` stores columns `r - kl ..= r + ku + kl`.
pub(crate) struct BandLu {
    pub(crate) n: usize,
    pub(crate) kl: usize,
    pub(crate) ku: usize,
    pub(crate) width: usize,
    pub(crate) a: Vec<f64>,
    pub(crate) rhs: Vec<f64>,
}

impl BandLu {
    pub(crate) fn new(n: usize, kl: usize, ku: usize) -> BandLu {
        let width = 2 * kl + ku + 1;
        BandLu {
            n,
            kl,
            ku,
            width,
            a: vec![0.0; n * width],
            rhs: vec![0.0; n],
        }
    }

    /// Entry (r, c), |c - r| within the band.
    #[cfg(test)]
    pub(crate) fn at(&mut self, r: usize, c: usize) -> &mut f64 {
        let i = r * self.width + c + self.kl - r;
        &mut self.a[i]
    }

    /// Solves in place (`rhs` becomes the solution); false if a pivot is zero or not finite.
    pub(crate) fn solve(&mut self) -> bool {
        let (n, kl, ku, w) = (self.n, self.kl, self.ku, self.width);
        let span = kl + ku + 1;
        for k in 0..n {
            let last = (k + kl).min(n - 1);
            let len = (k + kl + ku).min(n - 1) + 1 - k;
            let (mut p, mut best) = (k, self.a[k * w + kl].abs());
            for r in k + 1..=last {
                let v = self.a[r * w + k + kl - r].abs();
                if v > best {
                    (p, best) = (r, v);
                }
            }
            if !(best > 0.0 && best.is_finite()) {
                return false;
            }
            if p != k {
                let (lo, hi) = self.a.split_at_mut(p * w);
                let (rk, rp) = (k * w + kl, k + kl - p);
                lo[rk..rk + len].swap_with_slice(&mut hi[rp..rp + len]);
                self.rhs.swap(k, p);
            }
            let (head, tail) = self.a.split_at_mut((k + 1) * w);
            let row_k = &head[k * w + kl..k * w + kl + span];
            let (pivot, rhs_k) = (row_k[0], self.rhs[k]);
            for r in k + 1..=last {
                let start = (r - k - 1) * w + k + kl - r;
                let row_r = &mut tail[start..start + span];
                let m = row_r[0] / pivot;
                if m == 0.0 {
                    continue;
                }
                row_r[0] = 0.0;
                for (x, y) in row_r[1..len].iter_mut().zip(&row_k[1..len]) {
                    *x -= m * y;
                }
                self.rhs[r] -= m * rhs_k;
            }
        }
        for k in (0..n).rev() {
            let len = (k + kl + ku).min(n - 1) + 1 - k;
            let row_k = &self.a[k * w + kl..k * w + kl + len];
            let mut s = self.rhs[k];
            for (u, x) in row_k[1..].iter().zip(&self.rhs[k + 1..k + len]) {
                s -= u * x;
            }
            self.rhs[k] = s / row_k[0];
        }
        self.rhs.iter().all(|x| x.is_finite())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    pub(crate) fn band_lu_pivots() {
        // [[0, 1, 0], [1, 0, 1], [0, 1, 1]] x = [1, 2, 3] -> x = [0, 1, 2]; needs a row swap.
        let mut m = BandLu::new(3, 1, 1);
        for (r, c, v) in [
            (0, 1, 1.0),
            (1, 0, 1.0),
            (1, 2, 1.0),
            (2, 1, 1.0),
            (2, 2, 1.0),
        ] {
            *m.at(r, c) = v;
        }
        m.rhs.copy_from_slice(&[1.0, 2.0, 3.0]);
        assert!(m.solve());
        for (x, want) in m.rhs.iter().zip([0.0, 1.0, 2.0]) {
            assert_relative_eq!(*x, want, epsilon = 1e-15);
        }
        let mut singular = BandLu::new(2, 1, 1);
        assert!(!singular.solve());
    }
}
