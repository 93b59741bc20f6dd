//! Spherical B-splines: de Boor's algorithm with SLERP in place of every affine step
//! (GLS-PIA paper §3.2, eqs. 3–5), and the contribution coefficients D_i(t) of each control point
//! computed in the same pass (§5.1, eqs. 20–21).
//!
//! Every SLERP is a linear combination `w0 a + w1 b` with scalar weights, so propagating a
//! coefficient vector through the de Boor triangle alongside the points gives D_i(t) with
//! `C(t) = Σ D_i(t) P_i` exactly (to rounding), for any spread of the control points.

use crate::sphere::curve::SphericalCurve;
use crate::sphere::geometry::point::{normalize, Arc, Dim, Dynamic, PointSet};
use crate::sphere::SphereError;
use rayon::prelude::*;

/// Highest supported degree. Degree 5 already gives C^4 curves; higher degrees only add
/// oscillation and cost.
pub const MAX_DEGREE: usize = 5;

/// The degree of a de Boor kernel as a compile-time constant: every supported degree (1 to
/// [`MAX_DEGREE`]) is compiled in, so the triangle's loops unroll completely (with a runtime
/// degree they cost about twice the instructions; `benches/sphere.rs`, `examples/profile_pass.rs`).
pub(crate) trait Degree: Copy + Send + Sync + 'static {
    fn get(self) -> usize;
}

/// Degree `P` known at compile time.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Deg<const P: usize>;

impl<const P: usize> Degree for Deg<P> {
    #[inline(always)]
    fn get(self) -> usize {
        P
    }
}

/// Runs `$body` with `$g` bound to `Deg<p>` for the runtime degree `p` (1 to 5, validated when
/// the spline was built).
macro_rules! with_degree {
    ($p:expr, |$g:ident| $body:expr) => {{
        use $crate::sphere::curve::bspline::Deg;
        match $p {
            1 => {
                let $g = Deg::<1>;
                $body
            }
            2 => {
                let $g = Deg::<2>;
                $body
            }
            3 => {
                let $g = Deg::<3>;
                $body
            }
            4 => {
                let $g = Deg::<4>;
                $body
            }
            _ => {
                debug_assert_eq!($p, 5);
                let $g = Deg::<5>;
                $body
            }
        }
    }};
}
pub(crate) use with_degree;

/// The clamped uniform knot vector on [0, 1] for `n_ctrl` control points of degree `p`: `p + 1`
/// zeros, `i / (n_ctrl − p)` for `i` in `1..n_ctrl − p`, `p + 1` ones. Needs `n_ctrl > p`.
pub fn clamped_uniform_knots(n_ctrl: usize, p: usize) -> Vec<f64> {
    let m = n_ctrl - p;
    let mut k = vec![0.0; p + 1];
    k.extend((1..m).map(|i| i as f64 / m as f64));
    k.extend(std::iter::repeat_n(1.0, p + 1));
    k
}

/// A clamped spherical B-spline curve on S^n.
#[derive(Clone, Debug, PartialEq)]
pub struct SphericalBSpline {
    degree: usize,
    knots: Vec<f64>,
    control: PointSet,
}

impl SphericalBSpline {
    /// Builds a spline after validating it: degree 1 to [`MAX_DEGREE`], at least degree + 1
    /// control points, `control + degree + 1` finite non-decreasing knots, clamped ends
    /// (degree + 1 equal knots at each end), interior multiplicity at most `degree`, a non-empty
    /// domain and no (nearly) antipodal neighbouring control points.
    ///
    /// # Errors
    /// The first violated rule, naming the offending knot or control point index.
    pub fn try_new(
        degree: usize,
        knots: Vec<f64>,
        control: PointSet,
    ) -> Result<SphericalBSpline, SphereError> {
        check_degree(degree)?;
        let n = control.len();
        if n < degree + 1 {
            return Err(SphereError::InvalidControlPointCount {
                got: n,
                degree,
                min: degree + 1,
                max: usize::MAX,
            });
        }
        validate_knots(degree, n, &knots)?;
        control.check_no_antipodal_neighbours()?;
        Ok(SphericalBSpline {
            degree,
            knots,
            control,
        })
    }

    /// Whether the knot vector is [`clamped_uniform_knots`] for this degree and control-point
    /// count, so that it need not be stored.
    pub fn has_clamped_uniform_knots(&self) -> bool {
        self.knots == clamped_uniform_knots(self.control.len(), self.degree)
    }

    /// Polynomial degree p.
    pub fn degree(&self) -> usize {
        self.degree
    }

    /// The clamped knot vector (length = control points + degree + 1).
    pub fn knots(&self) -> &[f64] {
        &self.knots
    }

    /// The control points (unit vectors).
    pub fn control_points(&self) -> &PointSet {
        &self.control
    }

    /// Mutable control points, for the fitter (which keeps them unit vectors).
    pub(crate) fn control_points_mut(&mut self) -> &mut PointSet {
        &mut self.control
    }

    /// Number of coordinates per point.
    pub fn dim(&self) -> usize {
        self.control.dim()
    }

    /// Parameter domain `[u_p, u_n]`; evaluation clamps to it.
    pub fn domain(&self) -> (f64, f64) {
        (self.knots[self.degree], self.knots[self.control.len()])
    }

    /// The point C(t) (a unit vector); `t` is clamped to [`domain`](Self::domain).
    pub fn evaluate(&self, t: f64) -> Vec<f64> {
        let mut out = vec![0.0; self.dim()];
        self.eval_once::<false>(t, &mut out);
        out
    }

    /// C(t) into `out` by a frame and scratch of its own; returns the span and the scratch
    /// (with `CONTRIB`, holding the contribution coefficients).
    fn eval_once<const CONTRIB: bool>(&self, t: f64, out: &mut [f64]) -> (usize, Scratch) {
        let frame = Frame::new(self.degree, &self.knots, &self.control);
        let mut scratch = Scratch::new(self.degree, self.dim());
        let k = frame.span(t);
        with_degree!(self.degree, |g| frame.eval::<_, _, CONTRIB, false>(
            Dynamic(self.dim()),
            g,
            k,
            t,
            &mut scratch,
            out
        ));
        (k, scratch)
    }

    /// C(t) and the contribution coefficients D_i(t) of the control points that influence it.
    pub fn contributions(&self, t: f64) -> Contributions {
        let mut point = vec![0.0; self.dim()];
        let (k, scratch) = self.eval_once::<true>(t, &mut point);
        Contributions {
            first: k - self.degree,
            coefficients: scratch.contrib[..=self.degree].to_vec(),
            point,
        }
    }

    /// C(t) at every parameter of `ts` (in parallel for long inputs).
    pub fn evaluate_many(&self, ts: &[f64]) -> PointSet {
        let dim = self.dim();
        let mut coords = vec![0.0; ts.len() * dim];
        self.evaluate_into(ts, &mut coords);
        PointSet::from_flat_unchecked(dim, coords)
    }

    /// [`evaluate_many`](Self::evaluate_many) into `coords` (`ts.len() * dim` values).
    pub fn evaluate_into(&self, ts: &[f64], coords: &mut [f64]) {
        crate::with_dim!(self.dim(), |d| with_degree!(self.degree, |g| self
            .evaluate_into_in(d, g, ts, coords)));
    }

    fn evaluate_into_in<D: Dim, G: Degree>(&self, d: D, g: G, ts: &[f64], coords: &mut [f64]) {
        const CHUNK: usize = 4096;
        let dim = d.get();
        // The cache costs a SLERP set-up per control arc: worth it for passes over many
        // parameters, not for the handful a certification step evaluates at a time (on a
        // 500-control-point curve the cache was 57 % of a dense sampling's time).
        if ts.len() * 4 < self.control.len() {
            let frame = Frame::new(self.degree, &self.knots, &self.control);
            let mut scratch = Scratch::new(self.degree, dim);
            let mut k = frame.span(ts.first().copied().unwrap_or(0.0));
            for (t, o) in ts.iter().zip(coords.chunks_exact_mut(dim)) {
                k = frame.span_from(k, *t);
                frame.eval::<D, G, false, false>(d, g, k, *t, &mut scratch, o);
            }
            return;
        }
        let frame = Frame::cached(d, self.degree, &self.knots, &self.control);
        coords
            .par_chunks_mut(CHUNK * dim)
            .zip(ts.par_chunks(CHUNK))
            .for_each(|(out, ts)| {
                let mut scratch = Scratch::new(self.degree, dim);
                let mut k = frame.span(ts[0]);
                for (t, o) in ts.iter().zip(out.chunks_exact_mut(dim)) {
                    k = frame.span_from(k, *t);
                    frame.eval::<D, G, false, true>(d, g, k, *t, &mut scratch, o);
                }
            });
    }
}

impl SphericalCurve for SphericalBSpline {
    fn dim(&self) -> usize {
        self.control.dim()
    }
    fn domain(&self) -> (f64, f64) {
        SphericalBSpline::domain(self)
    }
    fn evaluate_many(&self, ts: &[f64]) -> PointSet {
        SphericalBSpline::evaluate_many(self, ts)
    }
    fn evaluate_into(&self, ts: &[f64], out: &mut [f64]) {
        SphericalBSpline::evaluate_into(self, ts, out)
    }
    fn speed_bound(&self, t0: f64, t1: f64) -> f64 {
        SphericalBSpline::speed_bound(self, t0, t1)
    }
    fn acceleration_bound(&self, t0: f64, t1: f64) -> f64 {
        SphericalBSpline::acceleration_bound(self, t0, t1)
    }
    fn breaks(&self) -> Vec<f64> {
        let (a, b) = self.domain();
        let mut out: Vec<f64> = Vec::new();
        for &u in &self.knots {
            if u > a && u < b && out.last() != Some(&u) {
                out.push(u);
            }
        }
        out
    }
    fn as_polyline(&self) -> Option<(&[f64], &PointSet)> {
        // Degree 1: vertex i is C(u_(i+1)), and the curve between two vertices is their
        // SLERP (one de Boor level). A repeated interior knot would make the curve jump.
        let n = self.control.len();
        let params = &self.knots[1..=n];
        (self.degree == 1 && params.windows(2).all(|w| w[0] < w[1]))
            .then_some((params, &self.control))
    }
}

impl SphericalBSpline {
    /// An upper bound of |C'(t)| (radians per unit of t) over `[t0, t1]`: the largest of the
    /// per-span bounds of the SLERP triangle (see [`crate::sphere::certify::bounds`]) over the spans the
    /// interval meets.
    pub fn speed_bound(&self, t0: f64, t1: f64) -> f64 {
        let (lo, hi) = self.domain();
        let (t0, t1) = (t0.clamp(lo, hi), t1.clamp(lo, hi));
        let (t0, t1) = (t0.min(t1), t0.max(t1));
        let p = self.degree;
        let frame = Frame::new(p, &self.knots, &self.control);
        let dim = self.dim();
        BOUND_SCRATCH.with_borrow_mut(|scratch| {
            let mut k = frame.span(t0);
            let mut best: f64 = 0.0;
            loop {
                let (a, b) = (t0.max(self.knots[k]), t1.min(self.knots[k + 1]));
                let u = &self.knots;
                let ctrl = &self.control.as_flat()[(k - p) * dim..(k + 1) * dim];
                let s = crate::sphere::certify::bounds::triangle_speed_bound(
                    dim,
                    ctrl,
                    span_alphas(u, k, p, (a, b.max(a))),
                    (b - a).max(0.0),
                    scratch,
                );
                best = best.max(s);
                if k >= frame.last_span || self.knots[k + 1] >= t1 {
                    break;
                }
                k += 1;
                while k < frame.last_span && self.knots[k + 1] <= self.knots[k] {
                    k += 1;
                }
            }
            best
        })
    }

    /// An upper bound of |C''(t)| (ambient, radians per unit of t squared) over `[t0, t1]`
    /// when the interval lies within one knot span (`triangle_acceleration_bound` in
    /// `sphere::certify::bounds`; proofs in `docs/certified-distance.md`); infinity when it
    /// crosses a knot, where the curve need not be twice differentiable.
    pub fn acceleration_bound(&self, t0: f64, t1: f64) -> f64 {
        let (lo, hi) = self.domain();
        let (t0, t1) = (t0.clamp(lo, hi), t1.clamp(lo, hi));
        let (a, b) = (t0.min(t1), t0.max(t1));
        let p = self.degree;
        let frame = Frame::new(p, &self.knots, &self.control);
        let k = frame.span(a);
        let u = &self.knots;
        if b > u[k + 1] {
            return f64::INFINITY;
        }
        let dim = self.dim();
        let ctrl = &self.control.as_flat()[(k - p) * dim..(k + 1) * dim];
        BOUND_SCRATCH.with_borrow_mut(|scratch| {
            crate::sphere::certify::bounds::triangle_acceleration_bound(
                dim,
                ctrl,
                span_alphas(u, k, p, (a, b)),
                b - a,
                scratch,
            )
        })
    }
}

/// The alphas of the de Boor triangle of span `k` over `t in [a, b]`, as the SLERP-triangle
/// bounds of [`crate::sphere::certify::bounds`] take them.
fn span_alphas(
    u: &[f64],
    k: usize,
    p: usize,
    (a, b): (f64, f64),
) -> impl Fn(usize, usize) -> crate::sphere::certify::bounds::NodeAlpha + '_ {
    move |r, j| {
        let i = k - p + j;
        let den = u[i + p - r + 1] - u[i];
        let inv = if den > 0.0 { 1.0 / den } else { 0.0 };
        crate::sphere::certify::bounds::NodeAlpha {
            at_start: (a - u[i]) * inv,
            at_end: (b - u[i]) * inv,
            slope: inv,
        }
    }
}

thread_local! {
    /// The SLERP triangle the speed and acceleration bounds work in, kept per thread: dense
    /// sampling asks for thousands of bounds per curve, and a fresh vector each time was a
    /// measured share of its cost (allocation and free).
    static BOUND_SCRATCH: std::cell::RefCell<Vec<f64>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// C(t) together with D_i(t) for the `degree + 1` control points `first ..= first + degree`.
#[derive(Clone, Debug, PartialEq)]
pub struct Contributions {
    /// Index of the first control point that influences C(t).
    pub first: usize,
    /// D_{first + m}(t) for m = 0 ..= degree.
    pub coefficients: Vec<f64>,
    /// C(t).
    pub point: Vec<f64>,
}

/// A degree the library evaluates: 1 ..= [`MAX_DEGREE`].
///
/// # Errors
/// [`SphereError::InvalidDegree`] otherwise.
pub(crate) fn check_degree(degree: usize) -> Result<(), SphereError> {
    if degree == 0 || degree > MAX_DEGREE {
        return Err(SphereError::InvalidDegree {
            got: degree,
            max: MAX_DEGREE,
        });
    }
    Ok(())
}

fn validate_knots(p: usize, n: usize, knots: &[f64]) -> Result<(), SphereError> {
    let bad = |reason: String| Err(SphereError::InvalidKnots { reason });
    if knots.len() != n + p + 1 {
        return bad(format!(
            "expected {} knots (control points {n} + degree {p} + 1), got {}",
            n + p + 1,
            knots.len()
        ));
    }
    if let Err(reason) = crate::sphere::finite_non_decreasing(knots, "knot") {
        return bad(reason);
    }
    if let Some(i) = (1..=p).find(|&i| knots[i] != knots[0]) {
        return bad(format!(
            "knot {i} differs from knot 0: a clamped spline starts with degree + 1 = {} equal knots",
            p + 1
        ));
    }
    if let Some(i) = (n..n + p).find(|&i| knots[i] != knots[n + p]) {
        return bad(format!(
            "knot {i} differs from the last knot: a clamped spline ends with degree + 1 = {} equal knots",
            p + 1
        ));
    }
    if knots[p] >= knots[n] {
        return bad("the domain [knot p, knot n] is empty".to_string());
    }
    // Spans that over- or underflow make the basis functions NaN: refuse them here rather
    // than return points that are not numbers.
    if !(knots[n] - knots[p]).is_finite() {
        return bad(format!(
            "the domain [knot {p}, knot {n}] is wider than the largest finite number: rescale the knots"
        ));
    }
    if let Some(i) = (p..n).find(|&i| {
        let s = knots[i + 1] - knots[i];
        s > 0.0 && !s.is_normal()
    }) {
        return bad(format!(
            "knot {}: the span from knot {i} ({:e}) is below the smallest normal number (about 2.2e-308): rescale the knots",
            i + 1,
            knots[i + 1] - knots[i]
        ));
    }
    let mut run = 1;
    for i in p + 2..n {
        run = if knots[i] == knots[i - 1] { run + 1 } else { 1 };
        if run > p {
            return bad(format!(
                "knot {i}: interior multiplicity {run} exceeds the degree {p} (the curve would break)"
            ));
        }
    }
    Ok(())
}

/// Arcs between consecutive control points: `arcs[i]` spans control `i - 1` to `i` (`arcs[0]`
/// is unused). The first de Boor level SLERPs exactly these pairs at every parameter, so the
/// angle and its sine are computed once per curve, not once per evaluation.
pub(crate) fn control_arcs<D: Dim>(d: D, control: &PointSet) -> Vec<Arc> {
    let mut arcs = Vec::with_capacity(control.len());
    arcs.push(Arc::from_angle(0.0));
    for i in 1..control.len() {
        arcs.push(Arc::between(d, control.get(i - 1), control.get(i)));
    }
    arcs
}

/// Per-thread working memory for de Boor: the triangle's points, its SLERP weights and the
/// contribution coefficients.
pub(crate) struct Scratch {
    /// The triangle's points on the stack up to [`TRI_INLINE`] values (a cubic on S^7, most
    /// fits): one scratch is made per evaluation batch, thousands per curve when certifying.
    tri_inline: [f64; TRI_INLINE],
    /// The triangle's points when they do not fit inline (empty otherwise).
    tri_heap: Vec<f64>,
    /// `weights[r][j]`: the SLERP weights that made node (r, j) of the triangle.
    weights: [[(f64, f64); MAX_DEGREE + 1]; MAX_DEGREE + 1],
    /// After a contributing evaluation in span k: `contrib[m]` = D_{k−p+m}(t), m = 0..=p.
    pub(crate) contrib: [f64; MAX_DEGREE + 1],
}

/// Triangle values a [`Scratch`] keeps on the stack.
const TRI_INLINE: usize = 32;

impl Scratch {
    pub(crate) fn new(p: usize, dim: usize) -> Scratch {
        Scratch {
            tri_inline: [0.0; TRI_INLINE],
            tri_heap: if (p + 1) * dim > TRI_INLINE {
                vec![0.0; (p + 1) * dim]
            } else {
                Vec::new()
            },
            weights: [[(0.0, 0.0); MAX_DEGREE + 1]; MAX_DEGREE + 1],
            contrib: [0.0; MAX_DEGREE + 1],
        }
    }
}

/// A spline's parts as de Boor needs them, borrowed (the fitter swaps control points each
/// iteration while knots stay put), plus optional per-curve caches for the hot loops.
pub(crate) struct Frame<'a> {
    pub(crate) p: usize,
    knots: &'a [f64],
    control: &'a PointSet,
    pub(crate) last_span: usize,
    n_ctrl: usize,
    /// `arcs[i]`: control i − 1 to i. Level 1 of the triangle SLERPs exactly these pairs at every
    /// parameter of a span, so their angles are computed once per curve (empty when uncached).
    arcs: Vec<Arc>,
    /// `1 / (u_{i+p−r+1} − u_i)` for every span and triangle node: the alphas' denominators
    /// depend only on the knots (empty when uncached).
    inv_den: Vec<f64>,
}

/// Index of triangle node (r, j), 1 <= r <= j <= p, in a span's block of p(p+1)/2 values.
#[inline(always)]
fn node_index(p: usize, r: usize, j: usize) -> usize {
    (r - 1) * (p + 1) - (r - 1) * r / 2 + (j - r)
}

impl<'a> Frame<'a> {
    /// A frame without caches, for evaluating at a few parameters.
    pub(crate) fn new(p: usize, knots: &'a [f64], control: &'a PointSet) -> Frame<'a> {
        let n = control.len();
        let last_span = (p..n).rev().find(|&k| knots[k] < knots[k + 1]).unwrap_or(p);
        Frame {
            p,
            knots,
            control,
            last_span,
            n_ctrl: n,
            arcs: Vec::new(),
            inv_den: Vec::new(),
        }
    }

    /// A frame with the control arcs and alpha denominators cached, for passes over many
    /// parameters (use `eval::<_, _, _, true>`).
    pub(crate) fn cached<D: Dim>(
        d: D,
        p: usize,
        knots: &'a [f64],
        control: &'a PointSet,
    ) -> Frame<'a> {
        let mut f = Frame::new(p, knots, control);
        f.arcs = control_arcs(d, control);
        let block = p * (p + 1) / 2;
        f.inv_den = vec![0.0; (f.n_ctrl - p) * block];
        for k in p..f.n_ctrl {
            for r in 1..=p {
                for j in r..=p {
                    let i = k - p + j;
                    let den = knots[i + p - r + 1] - knots[i];
                    f.inv_den[(k - p) * block + node_index(p, r, j)] =
                        if den > 0.0 { 1.0 / den } else { 0.0 };
                }
            }
        }
        f
    }

    /// The span k (p <= k <= n - 1) with `u_k <= t < u_{k+1}`; parameters before the domain
    /// use the first span, at or after its end the last non-empty one.
    #[inline]
    pub(crate) fn span(&self, t: f64) -> usize {
        let k = self.knots.partition_point(|&u| u <= t).saturating_sub(1);
        k.clamp(self.p, self.last_span)
    }

    /// [`span`](Self::span) starting from a nearby guess (parameters usually come sorted).
    #[inline(always)]
    pub(crate) fn span_from(&self, hint: usize, t: f64) -> usize {
        let k = hint;
        if self.knots[k] <= t && (t < self.knots[k + 1] || k == self.last_span) {
            return k;
        }
        if k < self.last_span && self.knots[k + 1] <= t && t < self.knots[k + 2] {
            return k + 1;
        }
        self.span(t)
    }

    /// Evaluates C(t) in span `k` into `out` (normalised). With `CONTRIB`, `scratch.contrib`
    /// holds D_{k-p+m}(t), m = 0..=p, scaled by the same normalisation so `Σ D P = C` holds.
    #[inline(always)]
    pub(crate) fn eval<D: Dim, G: Degree, const CONTRIB: bool, const CACHED: bool>(
        &self,
        d: D,
        g: G,
        k: usize,
        t: f64,
        scratch: &mut Scratch,
        out: &mut [f64],
    ) {
        debug_assert_eq!(g.get(), self.p);
        let (p, dim, u) = (g.get(), d.get(), self.knots);
        if p == 1 && !CACHED {
            let arc = Arc::between(d, self.control.get(k - 1), self.control.get(k));
            return self.eval_linear::<D, CONTRIB>(d, k, t, &arc, scratch, out);
        }
        let t = t.clamp(u[p], u[self.n_ctrl]);
        let len = (p + 1) * dim;
        let tri = if len <= TRI_INLINE {
            &mut scratch.tri_inline[..len]
        } else {
            &mut scratch.tri_heap[..len]
        };
        // The p + 1 control points of span k are contiguous.
        tri.copy_from_slice(&self.control.as_flat()[(k - p) * dim..(k + 1) * dim]);
        debug_assert!(!CACHED || !self.arcs.is_empty());
        let block = p * (p + 1) / 2;
        let inv_den = if CACHED {
            &self.inv_den[(k - p) * block..(k - p + 1) * block]
        } else {
            &[]
        };
        for r in 1..p + 1 {
            for j in (r..p + 1).rev() {
                let i = k - p + j;
                let alpha = if CACHED {
                    (t - u[i]) * inv_den[node_index(p, r, j)]
                } else {
                    (t - u[i]) / (u[i + p - r + 1] - u[i])
                };
                let (left, right) = tri.split_at_mut(j * dim);
                let a = &left[(j - 1) * dim..j * dim];
                let b = &mut right[..dim];
                let (w0, w1) = if CACHED && r == 1 {
                    self.arcs[i].weights_unit(alpha)
                } else {
                    Arc::between(d, a, b).weights_unit(alpha)
                };
                for c in 0..dim {
                    b[c] = w0 * a[c] + w1 * b[c];
                }
                if CONTRIB {
                    scratch.weights[r][j] = (w0, w1);
                }
            }
        }
        let apex = &mut tri[p * dim..(p + 1) * dim];
        let norm = normalize(d, apex);
        out[..dim].copy_from_slice(apex);
        if CONTRIB {
            // (Exclusive ranges: `a..=b` loops do not unroll as well in the hot path.)
            // D_i is the sum over paths from P_i up to the apex of the products of the SLERP
            // weights on the path: push the apex's weight (1 / norm, for the normalisation)
            // down the triangle level by level. Node (r, j) = w0·(r−1, j−1) + w1·(r−1, j).
            let c = &mut scratch.contrib;
            c[p] = 1.0 / norm;
            for r in (1..p + 1).rev() {
                let w = &scratch.weights[r];
                c[r - 1] = w[r].0 * c[r];
                for j in r..p {
                    c[j] = w[j].1 * c[j] + w[j + 1].0 * c[j + 1];
                }
                c[p] *= w[p].1;
            }
        }
    }

    /// [`eval`](Self::eval) of a degree-1 curve in span `k`: one SLERP along `arc`, which
    /// must be `Arc::between` the span's two control points. Callers that evaluate many
    /// parameters on one span while the control points move between passes (the tolerance
    /// fitter) keep the arc themselves, which [`Frame::cached`] cannot do for them.
    #[inline(always)]
    pub(crate) fn eval_linear<D: Dim, const CONTRIB: bool>(
        &self,
        d: D,
        k: usize,
        t: f64,
        arc: &Arc,
        scratch: &mut Scratch,
        out: &mut [f64],
    ) {
        debug_assert_eq!(self.p, 1);
        let (dim, u) = (d.get(), self.knots);
        let t = t.clamp(u[1], u[self.n_ctrl]);
        let (a, b) = (self.control.get(k - 1), self.control.get(k));
        let (w0, w1) = arc.weights_unit((t - u[k]) / (u[k + 1] - u[k]));
        let out = &mut out[..dim];
        for x in 0..dim {
            out[x] = w0 * a[x] + w1 * b[x];
        }
        let norm = normalize(d, out);
        if CONTRIB {
            // As the general triangle gives them: the apex's weight 1 / norm pushed down.
            let inv = 1.0 / norm;
            scratch.contrib[0] = w0 * inv;
            scratch.contrib[1] = inv * w1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    fn circle_points(n: usize, spread: f64) -> PointSet {
        let rows: Vec<Vec<f64>> = (0..n)
            .map(|i| {
                let a = spread * (i as f64 / (n - 1) as f64 - 0.5);
                let b = spread * 0.3 * ((i as f64) * 1.7).sin();
                let v = [a.cos() * b.cos(), a.sin() * b.cos(), b.sin()];
                v.to_vec()
            })
            .collect();
        PointSet::try_from_rows(&rows).unwrap()
    }

    #[test]
    fn clamped_ends_interpolate() {
        for p in 1..=MAX_DEGREE {
            let cp = circle_points(8, 1.5);
            let s = SphericalBSpline::try_new(p, clamped_uniform_knots(8, p), cp.clone()).unwrap();
            let a = s.evaluate(0.0);
            let b = s.evaluate(1.0);
            for c in 0..3 {
                assert_relative_eq!(a[c], cp.get(0)[c], epsilon = 1e-15);
                assert_relative_eq!(b[c], cp.get(7)[c], epsilon = 1e-15);
            }
        }
    }

    #[test]
    fn contributions_reproduce_the_point_exactly() {
        let cp = circle_points(9, 2.5);
        let s = SphericalBSpline::try_new(3, clamped_uniform_knots(9, 3), cp.clone()).unwrap();
        for i in 0..=50 {
            let t = i as f64 / 50.0;
            let c = s.contributions(t);
            let mut sum = [0.0; 3];
            for (m, w) in c.coefficients.iter().enumerate() {
                assert!(*w >= -1e-15);
                for k in 0..3 {
                    sum[k] += w * cp.get(c.first + m)[k];
                }
            }
            for k in 0..3 {
                assert_relative_eq!(sum[k], c.point[k], epsilon = 1e-14);
            }
            let direct = s.evaluate(t);
            for k in 0..3 {
                assert_relative_eq!(direct[k], c.point[k], epsilon = 1e-15);
            }
        }
    }

    #[test]
    fn degree_one_is_the_geodesic_polyline() {
        let cp = circle_points(4, 1.0);
        let s =
            SphericalBSpline::try_new(1, vec![0.0, 0.0, 0.5, 0.7, 1.0, 1.0], cp.clone()).unwrap();
        let mid = s.evaluate(0.6);
        let expected = crate::sphere::geometry::point::slerp(cp.get(1), cp.get(2), 0.5).unwrap();
        for k in 0..3 {
            assert_relative_eq!(mid[k], expected[k], epsilon = 1e-15);
        }
    }

    #[test]
    fn invalid_knots_are_named() {
        let cp = circle_points(5, 1.0);
        let err = |knots: Vec<f64>| SphericalBSpline::try_new(2, knots, cp.clone()).unwrap_err();
        assert!(err(vec![0.0; 7]).to_string().contains("expected 8 knots"));
        let e = err(vec![0.0, 0.0, 0.0, 0.6, 0.4, 1.0, 1.0, 1.0]).to_string();
        assert!(e.contains("knot 4"), "{e}");
        let e = err(vec![0.0, 0.0, 0.1, 0.4, 0.6, 1.0, 1.0, 1.0]).to_string();
        assert!(e.contains("clamped"), "{e}");
        assert!(SphericalBSpline::try_new(2, vec![0., 0., 0., 0.5, 0.5, 1., 1., 1.], cp).is_ok());
        let cp6 = circle_points(6, 1.0);
        let e = SphericalBSpline::try_new(2, vec![0., 0., 0., 0.5, 0.5, 0.5, 1., 1., 1.], cp6);
        assert!(e.unwrap_err().to_string().contains("multiplicity 3"));
    }

    #[test]
    fn span_lookup_handles_ends_and_hints() {
        let cp = circle_points(6, 1.0);
        let knots = clamped_uniform_knots(6, 3);
        let f = Frame::new(3, &knots, &cp);
        assert_eq!(f.span(-1.0), 3);
        assert_eq!(f.span(0.0), 3);
        assert_eq!(f.span(1.0), 5);
        assert_eq!(f.span(2.0), 5);
        assert_eq!(f.span_from(3, 0.4), f.span(0.4));
        assert_eq!(f.span_from(5, 0.1), 3);
    }
}
