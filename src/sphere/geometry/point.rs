//! Unit vectors on S^n: geodesic angle, SLERP, log/exp maps and the named tolerances they use.
//!
//! # Representation
//! Points are stored flat (`PointSet`: one `Vec<f64>` with a runtime dimension), and the kernels
//! are generic over a `Dim` that is either a compile-time constant (`Fixed`) or a runtime
//! value (`Dynamic`). The dimension is chosen once at the edge (`with_dim!`),
//! so the S^2 and S^3 hot paths see `Fixed<3>` / `Fixed<4>`: slice lengths are constants, loops
//! unroll and bounds checks vanish, while S^14 or S^127 run the same code with a runtime length.
//! One implementation serves every dimension; `benches/sphere.rs` measures the fixed path against
//! the dynamic one on S^2.

use crate::sphere::SphereError;

/// Inputs whose norm differs from 1 by more than this are rejected as "not a unit vector";
/// inside it they are re-normalised. Wide enough for coordinates rounded to 4 decimals (the
/// paper's `0.7071`), narrow enough to catch a lon/lat pair or an un-normalised vector.
pub const UNIT_NORM_TOLERANCE: f64 = 1e-3;

/// Neighbours closer than this to antipodal are an error: SLERP's weights divide by sin(theta),
/// so at pi - 1e-6 rounding is amplified to about 1e-10 rad in the result, the most we accept.
pub const ANTIPODAL_MARGIN_RAD: f64 = 1e-6;

/// Below this angle SLERP uses the linear weights `(1 - t, t)`: the relative error of doing so
/// is about theta^2 / 6 < 1e-17, below rounding, and it avoids 0/0 for identical points.
pub const SMALL_ANGLE_RAD: f64 = 1e-8;

/// Arcs up to this angle take the polynomial path in `Arc::between` and `Arc::weights`:
/// truncated Taylor series of sin(x)/x (to x^12) and asin (to z^17) whose first omitted term is
/// below 1e-17 relative for |x| <= 0.25. In de Boor's triangle neighbouring points are almost
/// always this close, and the series are several times cheaper than libm's atan2 and sin_cos
/// (`benches/sphere.rs`). Larger arcs use libm.
pub(crate) const SERIES_ANGLE_MAX_RAD: f64 = 0.25;

/// (2 sin(SERIES_ANGLE_MAX_RAD / 2))^2: the squared chord of the largest series arc.
const SERIES_CHORD_SQ_MAX: f64 = 0.062_175_156_578_710_436;

/// Arcs up to this angle use the short series (`sinc_series_short`, `asinc_series_short`):
/// their first omitted terms are below 1e-19 relative here. Typical neighbouring control points
/// of a dense fit are 1e-4 to 1e-2 rad apart.
pub(crate) const SHORT_SERIES_ANGLE_MAX_RAD: f64 = 0.02;

/// (2 sin(SHORT_SERIES_ANGLE_MAX_RAD / 2))^2.
const SHORT_SERIES_CHORD_SQ_MAX: f64 = 3.999_866_668_444_4e-4;

/// sin(x)/x for |x| <= [`SHORT_SERIES_ANGLE_MAX_RAD`]: Taylor series through x^6 (the omitted
/// x^8/9! term is < 1e-19 there).
#[inline(always)]
pub(crate) fn sinc_series_short(x: f64) -> f64 {
    let y = x * x;
    1.0 + y * (-1.0 / 6.0 + y * (1.0 / 120.0 + y * (-1.0 / 5040.0)))
}

/// asin(z)/z for 0 <= z <= sin(SHORT_SERIES_ANGLE_MAX_RAD / 2): Taylor series through z^6
/// (the omitted term is < 1e-18 relative there).
#[inline(always)]
pub(crate) fn asinc_series_short(z: f64) -> f64 {
    let y = z * z;
    1.0 + y * (1.0 / 6.0 + y * (3.0 / 40.0 + y * (5.0 / 112.0)))
}

/// sin(x)/x for |x| <= [`SERIES_ANGLE_MAX_RAD`]: Taylor series through x^12 (the omitted
/// x^14/15! term is < 1e-17 there).
#[inline(always)]
pub(crate) fn sinc_series(x: f64) -> f64 {
    let y = x * x;
    1.0 + y
        * (-1.0 / 6.0
            + y * (1.0 / 120.0
                + y * (-1.0 / 5040.0
                    + y * (1.0 / 362_880.0
                        + y * (-1.0 / 39_916_800.0 + y * (1.0 / 6_227_020_800.0))))))
}

/// asin(z)/z for 0 <= z <= sin(SERIES_ANGLE_MAX_RAD / 2): Taylor series through z^16 (the
/// omitted term is < 1e-18 relative there).
#[inline(always)]
pub(crate) fn asinc_series(z: f64) -> f64 {
    let y = z * z;
    1.0 + y
        * (1.0 / 6.0
            + y * (3.0 / 40.0
                + y * (5.0 / 112.0
                    + y * (35.0 / 1152.0
                        + y * (63.0 / 2816.0
                            + y * (231.0 / 13_312.0
                                + y * (143.0 / 10_240.0 + y * (6435.0 / 557_056.0))))))))
}

/// The angle in [0, pi/2] whose sine is `s` (0 <= s <= 1), by the series where they are
/// exact to rounding (angles up to [`SERIES_ANGLE_MAX_RAD`] / 2) and by `asin` beyond: a
/// cross-track distance from its sine without libm's atan2.
#[inline(always)]
pub(crate) fn angle_from_sine(s: f64) -> f64 {
    // sin(SHORT_SERIES_ANGLE_MAX_RAD / 2) and sin(SERIES_ANGLE_MAX_RAD / 2), the ranges of the
    // two asin(z)/z series.
    const SHORT_MAX: f64 = 0.009_999_833_334_166_664;
    const MAX: f64 = 0.124_674_733_385_227_69;
    if s <= SHORT_MAX {
        s * asinc_series_short(s)
    } else if s <= MAX {
        s * asinc_series(s)
    } else {
        s.min(1.0).asin()
    }
}

/// The geodesic angle between two unit vectors from their squared chord `|a - b|^2` and squared
/// sum `|a + b|^2`, and the factor `angle / |a - b|` (1 when they coincide).
#[inline(always)]
pub(crate) fn angle_from_chords(m2: f64, p2: f64) -> (f64, f64) {
    let m = m2.sqrt();
    if m2 <= SHORT_SERIES_CHORD_SQ_MAX {
        let ratio = asinc_series_short(0.5 * m);
        (m * ratio, ratio)
    } else if m2 <= SERIES_CHORD_SQ_MAX {
        // |a - b| = 2 sin(θ/2), so θ = 2 asin(m / 2) and θ / m = asin(z) / z with z = m / 2.
        let ratio = asinc_series(0.5 * m);
        (m * ratio, ratio)
    } else {
        let theta = 2.0 * m.atan2(p2.sqrt());
        (theta, theta / m)
    }
}

/// The ambient dimension of the points a kernel works on (S^n lives in R^(n+1)).
pub(crate) trait Dim: Copy + Send + Sync + 'static {
    /// Number of coordinates per point.
    fn get(self) -> usize;
}

/// A dimension known at compile time: the fast path for S^2 (`Fixed<3>`) and S^3 (`Fixed<4>`).
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Fixed<const N: usize>;

impl<const N: usize> Dim for Fixed<N> {
    #[inline(always)]
    fn get(self) -> usize {
        N
    }
}

/// A dimension known only at run time, for any S^n.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Dynamic(pub(crate) usize);

impl Dim for Dynamic {
    #[inline(always)]
    fn get(self) -> usize {
        self.0
    }
}

/// Runs `$body` with `$d` bound to the fastest `Dim` for `$dim`: `Fixed<3>`, `Fixed<4>` or
/// `Dynamic`. This is the one place where the dimension is dispatched.
macro_rules! with_dim {
    ($dim:expr, |$d:ident| $body:expr) => {{
        match $dim {
            3 => {
                let $d = $crate::sphere::geometry::point::Fixed::<3>;
                $body
            }
            4 => {
                let $d = $crate::sphere::geometry::point::Fixed::<4>;
                $body
            }
            n => {
                let $d = $crate::sphere::geometry::point::Dynamic(n);
                $body
            }
        }
    }};
}
pub(crate) use with_dim;

/// Dot product of the first `d` coordinates.
#[inline(always)]
pub(crate) fn dot<D: Dim>(d: D, a: &[f64], b: &[f64]) -> f64 {
    let (a, b) = (&a[..d.get()], &b[..d.get()]);
    let mut s = 0.0;
    for k in 0..d.get() {
        s += a[k] * b[k];
    }
    s
}

/// Squared Euclidean norm of `a - b` (the squared chord of two unit vectors).
#[inline(always)]
pub(crate) fn diff_sq<D: Dim>(d: D, a: &[f64], b: &[f64]) -> f64 {
    let (a, b) = (&a[..d.get()], &b[..d.get()]);
    let mut m = 0.0;
    for k in 0..d.get() {
        let x = a[k] - b[k];
        m += x * x;
    }
    m
}

/// Squared Euclidean norm of `a - b` and of `a + b`, in one pass.
#[inline(always)]
pub(crate) fn diff_sum_sq<D: Dim>(d: D, a: &[f64], b: &[f64]) -> (f64, f64) {
    let (a, b) = (&a[..d.get()], &b[..d.get()]);
    let (mut m, mut p) = (0.0, 0.0);
    for k in 0..d.get() {
        let (x, y) = (a[k] - b[k], a[k] + b[k]);
        m += x * x;
        p += y * y;
    }
    (m, p)
}

/// Geometry of a pair of unit vectors, computed once and reused by SLERP.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Arc {
    /// Geodesic angle in radians, in [0, pi].
    pub theta: f64,
    /// sin(theta), from the chord lengths (accurate at both ends of [0, pi]).
    pub sin_theta: f64,
    /// cos(theta).
    pub cos_theta: f64,
    /// 1 / sinc(theta) on the series paths (theta <= [`SERIES_ANGLE_MAX_RAD`]), else unused.
    pub inv_sinc: f64,
}

/// Which formula an arc's SLERP weights use.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum WeightPath {
    ShortSeries,
    Series,
    Libm,
}

impl Arc {
    /// The arc from `a` to `b` (both unit vectors). The angle uses the atan2 form
    /// `2 atan2(|a - b|, |a + b|)`, accurate to rounding for every angle (arccos of the dot
    /// product loses about 8 digits near 0 and pi).
    #[inline(always)]
    pub fn between<D: Dim>(d: D, a: &[f64], b: &[f64]) -> Arc {
        let (m2, p2) = diff_sum_sq(d, a, b);
        let (theta, _) = angle_from_chords(m2, p2);
        // |a - b| = 2 sin(theta/2), |a + b| = 2 cos(theta/2).
        Arc {
            theta,
            sin_theta: 0.5 * m2.sqrt() * p2.sqrt(),
            cos_theta: 0.25 * (p2 - m2),
            inv_sinc: Arc::inv_sinc_of(theta),
        }
    }

    /// The arc of a given angle (radians, in [0, pi]).
    pub fn from_angle(theta: f64) -> Arc {
        Arc {
            theta,
            sin_theta: theta.sin(),
            cos_theta: theta.cos(),
            inv_sinc: Arc::inv_sinc_of(theta),
        }
    }

    #[inline(always)]
    fn path(theta: f64) -> WeightPath {
        if theta <= SHORT_SERIES_ANGLE_MAX_RAD {
            WeightPath::ShortSeries
        } else if theta <= SERIES_ANGLE_MAX_RAD {
            WeightPath::Series
        } else {
            WeightPath::Libm
        }
    }

    #[inline(always)]
    fn inv_sinc_of(theta: f64) -> f64 {
        match Arc::path(theta) {
            WeightPath::ShortSeries => 1.0 / sinc_series_short(theta),
            WeightPath::Series => 1.0 / sinc_series(theta),
            WeightPath::Libm => 0.0,
        }
    }

    /// [`weights`](Self::weights) for `t` in [0, 1], as de Boor's alphas always are.
    #[inline(always)]
    pub fn weights_unit(&self, t: f64) -> (f64, f64) {
        debug_assert!((0.0..=1.0).contains(&t));
        let s = 1.0 - t;
        match Arc::path(self.theta) {
            // sin(tθ)/sinθ = t · sinc(tθ) / sinc(θ): no 0/0 as θ → 0, exact to rounding.
            WeightPath::ShortSeries => (
                s * sinc_series_short(s * self.theta) * self.inv_sinc,
                t * sinc_series_short(t * self.theta) * self.inv_sinc,
            ),
            WeightPath::Series => (
                s * sinc_series(s * self.theta) * self.inv_sinc,
                t * sinc_series(t * self.theta) * self.inv_sinc,
            ),
            WeightPath::Libm => self.weights_libm(t),
        }
    }

    /// True when SLERP along this arc is ill-conditioned (see [`ANTIPODAL_MARGIN_RAD`]).
    #[inline]
    pub fn is_near_antipodal(&self) -> bool {
        self.theta > std::f64::consts::PI - ANTIPODAL_MARGIN_RAD
    }

    /// SLERP weights `(w0, w1)` with `slerp(a, b, t) = w0 a + w1 b`:
    /// `w0 = sin((1 - t) theta) / sin theta`, `w1 = sin(t theta) / sin theta` (GLS-PIA eq. 1).
    /// Below [`SMALL_ANGLE_RAD`] the linear weights are exact to rounding. Near-antipodal arcs
    /// are rejected where points enter the library; if one still arises inside an iteration,
    /// the weights stay finite (sin theta is floored) so nothing turns into NaN.
    #[inline(always)]
    pub fn weights(&self, t: f64) -> (f64, f64) {
        if (0.0..=1.0).contains(&t) {
            return self.weights_unit(t);
        }
        self.weights_libm(t)
    }

    #[inline]
    fn weights_libm(&self, t: f64) -> (f64, f64) {
        if self.theta < SMALL_ANGLE_RAD {
            return (1.0 - t, t);
        }
        let (s, c) = (t * self.theta).sin_cos();
        let inv = 1.0 / self.sin_theta.max(1e-300);
        let w1 = s * inv;
        // sin((1-t)θ) = sinθ cos(tθ) − cosθ sin(tθ)
        let w0 = c - self.cos_theta * w1;
        (w0, w1)
    }
}

/// Geodesic distance (angle in radians) between unit vectors `a` and `b`.
#[inline]
pub(crate) fn angle<D: Dim>(d: D, a: &[f64], b: &[f64]) -> f64 {
    let (m2, p2) = diff_sum_sq(d, a, b);
    angle_from_chords(m2, p2).0
}

/// Geodesic distance between two unit vectors of equal length (any dimension).
pub fn angle_between(a: &[f64], b: &[f64]) -> f64 {
    debug_assert_eq!(a.len(), b.len());
    angle(Dynamic(a.len()), a, b)
}

/// `out = w0 a + w1 b`.
#[inline(always)]
pub(crate) fn combine<D: Dim>(d: D, out: &mut [f64], w0: f64, a: &[f64], w1: f64, b: &[f64]) {
    let (out, a, b) = (&mut out[..d.get()], &a[..d.get()], &b[..d.get()]);
    for k in 0..d.get() {
        out[k] = w0 * a[k] + w1 * b[k];
    }
}

/// Normalises `v` in place and returns its former norm.
#[inline(always)]
pub(crate) fn normalize<D: Dim>(d: D, v: &mut [f64]) -> f64 {
    let v = &mut v[..d.get()];
    let n = dot(d, v, v).sqrt();
    if n > 0.0 {
        let inv = 1.0 / n;
        for x in v.iter_mut() {
            *x *= inv;
        }
    }
    n
}

/// SLERP (GLS-PIA eq. 1) from `a` (t = 0) to `b` (t = 1), written to `out` and re-normalised.
/// `t` outside [0, 1] extrapolates along the same great circle.
///
/// # Errors
/// [`SphereError::Antipodal`] (index 0) when `a` and `b` are within
/// [`ANTIPODAL_MARGIN_RAD`] of antipodal: every great circle through them is equally valid.
pub fn slerp(a: &[f64], b: &[f64], t: f64) -> Result<Vec<f64>, SphereError> {
    let d = Dynamic(a.len());
    check_same_len(a, b)?;
    let arc = Arc::between(d, a, b);
    if arc.is_near_antipodal() {
        return Err(SphereError::Antipodal {
            index: 0,
            angle_rad: arc.theta,
        });
    }
    let (w0, w1) = arc.weights(t);
    let mut out = vec![0.0; a.len()];
    combine(d, &mut out, w0, a, w1, b);
    normalize(d, &mut out);
    Ok(out)
}

fn check_same_len(a: &[f64], b: &[f64]) -> Result<(), SphereError> {
    if a.len() != b.len() {
        return Err(SphereError::DimensionMismatch {
            index: 1,
            expected: a.len(),
            got: b.len(),
        });
    }
    Ok(())
}

/// sin(x) / x, exact to rounding near 0.
#[inline]
pub fn sinc(x: f64) -> f64 {
    if x.abs() < 1e-4 {
        let x2 = x * x;
        1.0 - x2 / 6.0 * (1.0 - x2 / 20.0)
    } else {
        x.sin() / x
    }
}

/// Logarithm map: the tangent vector at `base` pointing along the geodesic to `p`, with length
/// equal to the geodesic distance (radians).
///
/// # Errors
/// [`SphereError::Antipodal`] when `p` is (nearly) antipodal to `base` (the direction is undefined).
pub fn log_map(base: &[f64], p: &[f64]) -> Result<Vec<f64>, SphereError> {
    check_same_len(base, p)?;
    let d = Dynamic(base.len());
    let arc = Arc::between(d, base, p);
    if arc.is_near_antipodal() {
        return Err(SphereError::Antipodal {
            index: 0,
            angle_rad: arc.theta,
        });
    }
    let mut out = vec![0.0; base.len()];
    log_into(d, base, p, &mut out);
    Ok(out)
}

/// The logarithm map at `base` towards `p` (tangent, length = angle in radians) into `out`.
/// Never fails: at the antipode (which callers rule out) the direction collapses to zero.
#[inline(always)]
pub(crate) fn log_into<D: Dim>(d: D, base: &[f64], p: &[f64], out: &mut [f64]) {
    let arc = Arc::between(d, base, p);
    // v = p - cos θ base has length sin θ; scale it to θ.
    let scale = 1.0 / sinc(arc.theta).max(1e-300);
    for c in 0..d.get() {
        out[c] = (p[c] - arc.cos_theta * base[c]) * scale;
    }
}

/// `p ← exp_p(t)`: walks from unit vector `p` along `t` (tangent at `p`) for `|t|` radians, in
/// place. The one exponential map: [`exp_map`] and the solvers' control-point moves use it.
#[inline]
pub(crate) fn exp_in_place<D: Dim>(d: D, p: &mut [f64], t: &[f64]) {
    let len = dot(d, t, t).sqrt();
    let (c, s) = (len.cos(), sinc(len));
    for x in 0..d.get() {
        p[x] = c * p[x] + s * t[x];
    }
    normalize(d, p);
}

/// Exponential map: walks from `base` along tangent vector `v` for `|v|` radians.
/// The component of `v` along `base` is removed first, so `v` need not be exactly tangent.
pub fn exp_map(base: &[f64], v: &[f64]) -> Result<Vec<f64>, SphereError> {
    check_same_len(base, v)?;
    let d = Dynamic(base.len());
    let along = dot(d, base, v);
    let t: Vec<f64> = v.iter().zip(base).map(|(x, b)| x - along * b).collect();
    let mut out = base.to_vec();
    exp_in_place(d, &mut out, &t);
    Ok(out)
}

/// An ordered set of points on S^n, stored flat (`dim` coordinates per point).
#[derive(Clone, Debug, PartialEq)]
pub struct PointSet {
    dim: usize,
    coords: Vec<f64>,
}

impl PointSet {
    /// Validates rows as unit vectors of one dimension (at least 2: S^1 and up), re-normalising
    /// those within [`UNIT_NORM_TOLERANCE`] of unit length.
    ///
    /// # Errors
    /// Empty input, a dimension below 2 or differing between rows, a non-finite coordinate, or a
    /// norm outside the tolerance; each error names the point index.
    pub fn try_from_rows<R: AsRef<[f64]>>(rows: &[R]) -> Result<PointSet, SphereError> {
        let first = rows
            .first()
            .ok_or(SphereError::TooFewPoints { got: 0, need: 1 })?;
        let dim = first.as_ref().len();
        if dim < 2 {
            return Err(SphereError::DimensionTooSmall { index: 0, got: dim });
        }
        let mut coords = Vec::with_capacity(rows.len() * dim);
        for (index, row) in rows.iter().enumerate() {
            let row = row.as_ref();
            if row.len() != dim {
                return Err(SphereError::DimensionMismatch {
                    index,
                    expected: dim,
                    got: row.len(),
                });
            }
            if let Some(coord) = row.iter().position(|x| !x.is_finite()) {
                return Err(SphereError::NotFinite { index, coord });
            }
            let start = coords.len();
            coords.extend_from_slice(row);
            let norm = normalize(Dynamic(dim), &mut coords[start..]);
            if (norm - 1.0).abs() > UNIT_NORM_TOLERANCE {
                return Err(SphereError::NotUnit { index, norm });
            }
        }
        Ok(PointSet { dim, coords })
    }

    /// Builds a set from coordinates that are already unit vectors (checked in debug builds).
    pub(crate) fn from_flat_unchecked(dim: usize, coords: Vec<f64>) -> PointSet {
        debug_assert!(dim >= 1 && coords.len() % dim == 0);
        PointSet { dim, coords }
    }

    /// The points at `indices`, in that order.
    ///
    /// # Panics
    /// If an index is out of range.
    pub(crate) fn subset(&self, indices: &[usize]) -> PointSet {
        let mut coords = Vec::with_capacity(indices.len() * self.dim);
        for &i in indices {
            coords.extend_from_slice(self.get(i));
        }
        PointSet {
            dim: self.dim,
            coords,
        }
    }

    /// Number of coordinates per point (n + 1 for S^n).
    pub fn dim(&self) -> usize {
        self.dim
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.coords.len() / self.dim
    }

    /// True when there are no points.
    pub fn is_empty(&self) -> bool {
        self.coords.is_empty()
    }

    /// Point `i` as a slice of `dim` coordinates.
    #[inline(always)]
    pub fn get(&self, i: usize) -> &[f64] {
        &self.coords[i * self.dim..(i + 1) * self.dim]
    }

    /// Mutable access to point `i`; the caller keeps it a unit vector.
    #[inline(always)]
    pub(crate) fn get_mut(&mut self, i: usize) -> &mut [f64] {
        &mut self.coords[i * self.dim..(i + 1) * self.dim]
    }

    /// Removes point `i` in place (no reallocation): the fitter's knot removals.
    pub(crate) fn remove(&mut self, i: usize) {
        self.coords.drain(i * self.dim..(i + 1) * self.dim);
    }

    /// Inserts `row` (of length `dim`) before point `i`, in place.
    pub(crate) fn insert(&mut self, i: usize, row: &[f64]) {
        debug_assert_eq!(row.len(), self.dim);
        let at = i * self.dim;
        self.coords.splice(at..at, row.iter().copied());
    }

    /// All coordinates, point after point.
    pub fn as_flat(&self) -> &[f64] {
        &self.coords
    }

    /// The points as rows.
    pub fn iter(&self) -> std::slice::ChunksExact<'_, f64> {
        self.coords.chunks_exact(self.dim)
    }

    /// The points as owned rows (for serialisation).
    pub fn to_rows(&self) -> Vec<Vec<f64>> {
        self.iter().map(<[f64]>::to_vec).collect()
    }

    /// Errors if two consecutive points are within [`ANTIPODAL_MARGIN_RAD`] of antipodal; the
    /// error names the index of the second point of the pair.
    pub fn check_no_antipodal_neighbours(&self) -> Result<(), SphereError> {
        let d = Dynamic(self.dim);
        for i in 1..self.len() {
            let arc = Arc::between(d, self.get(i - 1), self.get(i));
            if arc.is_near_antipodal() {
                return Err(SphereError::Antipodal {
                    index: i,
                    angle_rad: arc.theta,
                });
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn angle_is_accurate_near_zero_and_pi() {
        let a = [1.0, 0.0, 0.0];
        let tiny = 1e-12_f64;
        let b = [tiny.cos(), tiny.sin(), 0.0];
        assert_relative_eq!(angle_between(&a, &b), tiny, max_relative = 1e-9);
        let near_pi = std::f64::consts::PI - 1e-9;
        let c = [near_pi.cos(), near_pi.sin(), 0.0];
        assert_relative_eq!(angle_between(&a, &c), near_pi, max_relative = 1e-15);
    }

    #[test]
    fn series_match_libm_to_rounding() {
        let mut worst: f64 = 0.0;
        for i in 0..=10_000 {
            let x = SERIES_ANGLE_MAX_RAD * i as f64 / 10_000.0;
            let exact = if x == 0.0 { 1.0 } else { x.sin() / x };
            worst = worst.max((sinc_series(x) - exact).abs());
            // The series chord bound matches the angle bound.
            let a = [1.0, 0.0, 0.0];
            let b = [x.cos(), x.sin(), 0.0];
            let (m2, p2) = diff_sum_sq(Fixed::<3>, &a, &b);
            let theta = angle_from_chords(m2, p2).0;
            let reference = 2.0 * m2.sqrt().atan2(p2.sqrt());
            worst = worst.max((theta - reference).abs() / x.max(1e-300));
        }
        assert!(worst < 1e-15, "worst relative deviation {worst:e}");
        let edge = (2.0 * (SERIES_ANGLE_MAX_RAD / 2.0).sin()).powi(2);
        assert!((SERIES_CHORD_SQ_MAX - edge).abs() < 1e-16, "{edge:e}");
    }

    #[test]
    fn short_series_match_libm_to_rounding() {
        let mut worst: f64 = 0.0;
        for i in 0..=10_000 {
            let x = SHORT_SERIES_ANGLE_MAX_RAD * i as f64 / 10_000.0;
            let exact = if x == 0.0 { 1.0 } else { x.sin() / x };
            worst = worst.max((sinc_series_short(x) - exact).abs());
            let z = (x / 2.0).sin();
            let exact = if z == 0.0 { 1.0 } else { z.asin() / z };
            worst = worst.max((asinc_series_short(z) - exact).abs());
        }
        assert!(worst < 1e-15, "worst deviation {worst:e}");
        let edge = (2.0 * (SHORT_SERIES_ANGLE_MAX_RAD / 2.0).sin()).powi(2);
        assert!((SHORT_SERIES_CHORD_SQ_MAX - edge).abs() < 1e-17, "{edge:e}");
    }

    #[test]
    fn weights_agree_across_the_series_boundary() {
        for theta in [
            1e-12,
            1e-6,
            0.01,
            0.02,
            0.0200001,
            0.2,
            SERIES_ANGLE_MAX_RAD,
            0.2500001,
            1.0,
            3.0,
        ] {
            let arc = Arc::from_angle(theta);
            for t in [0.0, 0.1, 0.5, 0.9, 1.0] {
                let (w0, w1) = arc.weights(t);
                let e1 = if theta < 1e-9 {
                    t
                } else {
                    (t * theta).sin() / theta.sin()
                };
                let e0 = if theta < 1e-9 {
                    1.0 - t
                } else {
                    ((1.0 - t) * theta).sin() / theta.sin()
                };
                assert!(
                    (w0 - e0).abs() < 2e-15 && (w1 - e1).abs() < 2e-15,
                    "θ={theta} t={t}"
                );
            }
        }
    }

    #[test]
    fn slerp_midpoint_of_quarter_circle() {
        let m = slerp(&[1.0, 0.0, 0.0], &[0.0, 1.0, 0.0], 0.5).unwrap();
        let h = std::f64::consts::FRAC_1_SQRT_2;
        assert_relative_eq!(m[0], h, epsilon = 1e-15);
        assert_relative_eq!(m[1], h, epsilon = 1e-15);
    }

    #[test]
    fn slerp_of_identical_points_is_that_point() {
        let p = [0.0, 0.6, 0.8];
        let m = slerp(&p, &p, 0.3).unwrap();
        for k in 0..3 {
            assert_relative_eq!(m[k], p[k], epsilon = 1e-16);
        }
    }

    #[test]
    fn antipodal_slerp_is_an_error() {
        let e = slerp(&[0.0, 0.0, 1.0], &[0.0, 0.0, -1.0], 0.5).unwrap_err();
        assert!(matches!(e, SphereError::Antipodal { .. }));
    }

    #[test]
    fn log_then_exp_round_trips() {
        let base = [0.0, 0.0, 1.0];
        let p = [0.6, 0.0, 0.8];
        let v = log_map(&base, &p).unwrap();
        assert_relative_eq!(
            dot(Fixed::<3>, &v, &v).sqrt(),
            0.6_f64.asin(),
            epsilon = 1e-15
        );
        let q = exp_map(&base, &v).unwrap();
        for k in 0..3 {
            assert_relative_eq!(q[k], p[k], epsilon = 1e-15);
        }
    }

    #[test]
    fn point_set_rejects_bad_rows_by_index() {
        let e = PointSet::try_from_rows(&[vec![1.0, 0.0, 0.0], vec![1.0, 1.0, 0.0]]).unwrap_err();
        assert!(matches!(e, SphereError::NotUnit { index: 1, .. }));
        let e = PointSet::try_from_rows(&[vec![1.0, 0.0, 0.0], vec![1.0, 0.0]]).unwrap_err();
        assert!(matches!(e, SphereError::DimensionMismatch { index: 1, .. }));
        let e = PointSet::try_from_rows(&[vec![1.0, f64::NAN, 0.0]]).unwrap_err();
        assert!(matches!(e, SphereError::NotFinite { index: 0, coord: 1 }));
        let ps = PointSet::try_from_rows(&[vec![0.0, 0.0, 1.0], vec![0.0, 0.0, -1.0]]).unwrap();
        let e = ps.check_no_antipodal_neighbours().unwrap_err();
        assert!(matches!(e, SphereError::Antipodal { index: 1, .. }));
    }
}
