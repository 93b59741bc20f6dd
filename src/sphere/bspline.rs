//! Spherical B-splines: de Boor's algorithm with SLERP in place of every affine step
//! (GLS-PIA paper §3.2, eqs. 3–5), and the contribution coefficients D_i(t) of each control point
//! computed in the same pass (§5.1, eqs. 20–21).
//!
//! Every SLERP is a linear combination `w0 a + w1 b` with scalar weights, so propagating a
//! coefficient vector through the de Boor triangle alongside the points gives D_i(t) with
//! `C(t) = Σ D_i(t) P_i` exactly (to rounding), for any spread of the control points.

use super::curve::SphericalCurve;
use super::point::{normalize, Arc, Dim, Dynamic, PointSet};
use super::SphereError;
use rayon::prelude::*;

/// Highest supported degree. Degree 5 already gives C^4 curves; higher degrees only add
/// oscillation and cost.
pub const MAX_DEGREE: usize = 5;

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
        if degree == 0 || degree > MAX_DEGREE {
            return Err(SphereError::InvalidDegree {
                got: degree,
                max: MAX_DEGREE,
            });
        }
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
        let frame = Frame::new(self.degree, &self.knots, &self.control);
        let mut scratch = Scratch::new(self.degree, self.dim());
        let k = frame.span(t);
        frame.eval::<_, false>(Dynamic(self.dim()), k, t, &mut scratch, &mut out);
        out
    }

    /// C(t) and the contribution coefficients D_i(t) of the control points that influence it.
    pub fn contributions(&self, t: f64) -> Contributions {
        let mut point = vec![0.0; self.dim()];
        let frame = Frame::new(self.degree, &self.knots, &self.control);
        let mut scratch = Scratch::new(self.degree, self.dim());
        let k = frame.span(t);
        frame.eval::<_, true>(Dynamic(self.dim()), k, t, &mut scratch, &mut point);
        Contributions {
            first: k - self.degree,
            coefficients: scratch.coef[self.degree][..=self.degree].to_vec(),
            point,
        }
    }

    /// C(t) at every parameter of `ts` (in parallel for long inputs).
    pub fn evaluate_many(&self, ts: &[f64]) -> PointSet {
        let dim = self.dim();
        let mut coords = vec![0.0; ts.len() * dim];
        crate::with_dim!(dim, |d| self.evaluate_into(d, ts, &mut coords));
        PointSet::from_flat_unchecked(dim, coords)
    }

    fn evaluate_into<D: Dim>(&self, d: D, ts: &[f64], coords: &mut [f64]) {
        const CHUNK: usize = 4096;
        let dim = d.get();
        let arcs = control_arcs(d, &self.control);
        let frame = Frame::with_arcs(self.degree, &self.knots, &self.control, &arcs);
        coords
            .par_chunks_mut(CHUNK * dim)
            .zip(ts.par_chunks(CHUNK))
            .for_each(|(out, ts)| {
                let mut scratch = Scratch::new(self.degree, dim);
                let mut k = frame.span(ts[0]);
                for (t, o) in ts.iter().zip(out.chunks_exact_mut(dim)) {
                    k = frame.span_from(k, *t);
                    frame.eval::<D, false>(d, k, *t, &mut scratch, o);
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

fn validate_knots(p: usize, n: usize, knots: &[f64]) -> Result<(), SphereError> {
    let bad = |reason: String| Err(SphereError::InvalidKnots { reason });
    if knots.len() != n + p + 1 {
        return bad(format!(
            "expected {} knots (control points {n} + degree {p} + 1), got {}",
            n + p + 1,
            knots.len()
        ));
    }
    if let Some(i) = knots.iter().position(|u| !u.is_finite()) {
        return bad(format!("knot {i} is not a finite number"));
    }
    if let Some(i) = (1..knots.len()).find(|&i| knots[i] < knots[i - 1]) {
        return bad(format!(
            "knot {i} ({}) is smaller than knot {} ({}): knots must not decrease",
            knots[i],
            i - 1,
            knots[i - 1]
        ));
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
    arcs.push(Arc {
        theta: 0.0,
        sin_theta: 0.0,
        cos_theta: 1.0,
    });
    for i in 1..control.len() {
        arcs.push(Arc::between(d, control.get(i - 1), control.get(i)));
    }
    arcs
}

/// Per-thread working memory for de Boor: the triangle's points and coefficient vectors.
pub(crate) struct Scratch {
    tri: Vec<f64>,
    /// `coef[j][m]`: weight of base control `m` in the triangle's point `j`.
    pub(crate) coef: [[f64; MAX_DEGREE + 1]; MAX_DEGREE + 1],
}

impl Scratch {
    pub(crate) fn new(p: usize, dim: usize) -> Scratch {
        Scratch {
            tri: vec![0.0; (p + 1) * dim],
            coef: [[0.0; MAX_DEGREE + 1]; MAX_DEGREE + 1],
        }
    }
}

/// A spline's parts as de Boor needs them, borrowed (the fitter swaps control points each
/// iteration while knots stay put).
pub(crate) struct Frame<'a> {
    p: usize,
    knots: &'a [f64],
    control: &'a PointSet,
    arcs: Option<&'a [Arc]>,
    last_span: usize,
}

impl<'a> Frame<'a> {
    pub(crate) fn new(p: usize, knots: &'a [f64], control: &'a PointSet) -> Frame<'a> {
        let n = control.len();
        let last_span = (p..n).rev().find(|&k| knots[k] < knots[k + 1]).unwrap_or(p);
        Frame {
            p,
            knots,
            control,
            arcs: None,
            last_span,
        }
    }

    pub(crate) fn with_arcs(
        p: usize,
        knots: &'a [f64],
        control: &'a PointSet,
        arcs: &'a [Arc],
    ) -> Frame<'a> {
        Frame {
            arcs: Some(arcs),
            ..Frame::new(p, knots, control)
        }
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

    /// Evaluates C(t) in span `k` into `out` (normalised). With `CONTRIB`, `scratch.coef[p]`
    /// holds D_{k-p+m}(t), m = 0..=p, scaled by the same normalisation so `Σ D P = C` holds.
    #[inline(always)]
    pub(crate) fn eval<D: Dim, const CONTRIB: bool>(
        &self,
        d: D,
        k: usize,
        t: f64,
        scratch: &mut Scratch,
        out: &mut [f64],
    ) {
        let (p, dim, u) = (self.p, d.get(), self.knots);
        let t = t.clamp(u[p], u[self.control.len()]);
        let tri = &mut scratch.tri[..(p + 1) * dim];
        for j in 0..=p {
            tri[j * dim..(j + 1) * dim].copy_from_slice(self.control.get(k - p + j));
        }
        if CONTRIB {
            for (j, row) in scratch.coef.iter_mut().enumerate().take(p + 1) {
                *row = [0.0; MAX_DEGREE + 1];
                row[j] = 1.0;
            }
        }
        for r in 1..=p {
            for j in (r..=p).rev() {
                let i = k - p + j;
                let alpha = (t - u[i]) / (u[i + p - r + 1] - u[i]);
                let (left, right) = tri.split_at_mut(j * dim);
                let a = &left[(j - 1) * dim..j * dim];
                let b = &mut right[..dim];
                let arc = match (r, self.arcs) {
                    (1, Some(arcs)) => arcs[i],
                    _ => Arc::between(d, a, b),
                };
                let (w0, w1) = arc.weights(alpha);
                for c in 0..dim {
                    b[c] = w0 * a[c] + w1 * b[c];
                }
                if CONTRIB {
                    let (lo, hi) = scratch.coef.split_at_mut(j);
                    let (prev, cur) = (&lo[j - 1], &mut hi[0]);
                    for m in j - r..=j {
                        cur[m] = w0 * prev[m] + w1 * cur[m];
                    }
                }
            }
        }
        let apex = &mut tri[p * dim..(p + 1) * dim];
        let norm = normalize(d, apex);
        out[..dim].copy_from_slice(apex);
        if CONTRIB {
            let inv = 1.0 / norm;
            for c in scratch.coef[p][..=p].iter_mut() {
                *c *= inv;
            }
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

    fn clamped_uniform(n: usize, p: usize) -> Vec<f64> {
        let mut k = vec![0.0; p + 1];
        for i in 1..n - p {
            k.push(i as f64 / (n - p) as f64);
        }
        k.extend(std::iter::repeat_n(1.0, p + 1));
        k
    }

    #[test]
    fn clamped_ends_interpolate() {
        for p in 1..=MAX_DEGREE {
            let cp = circle_points(8, 1.5);
            let s = SphericalBSpline::try_new(p, clamped_uniform(8, p), cp.clone()).unwrap();
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
        let s = SphericalBSpline::try_new(3, clamped_uniform(9, 3), cp.clone()).unwrap();
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
        let expected = super::super::point::slerp(cp.get(1), cp.get(2), 0.5).unwrap();
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
        let knots = clamped_uniform(6, 3);
        let f = Frame::new(3, &knots, &cp);
        assert_eq!(f.span(-1.0), 3);
        assert_eq!(f.span(0.0), 3);
        assert_eq!(f.span(1.0), 5);
        assert_eq!(f.span(2.0), 5);
        assert_eq!(f.span_from(3, 0.4), f.span(0.4));
        assert_eq!(f.span_from(5, 0.1), 3);
    }
}
