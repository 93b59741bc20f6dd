//! Tangent frames carried along piecewise-geodesic paths by parallel transport, and the
//! *development* of such a path into the tangent space R^n: rolling the sphere without slipping
//! along the path traces a polyline in the plane whose segments have the arcs' lengths and whose
//! turning angles are the path's. Jupp–Kent unwrapping and the Palais-metric gradient of Samir
//! et al. both work in these coordinates.

use crate::sphere::geometry::point::{
    dot, exp_in_place, log_into, normalize, Arc, Dynamic, PointSet,
};

/// An orthonormal basis of the tangent space T_p S^n: `n = dim - 1` vectors of `dim`
/// coordinates each, stored row after row.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Frame {
    pub(crate) dim: usize,
    pub(crate) rows: Vec<f64>,
}

impl Frame {
    /// A frame at the unit vector `p`: Gram–Schmidt on the coordinate axes, skipping the axis
    /// most aligned with `p`.
    pub(crate) fn at(p: &[f64]) -> Frame {
        let dim = p.len();
        let d = Dynamic(dim);
        let skip = (0..dim)
            .max_by(|&a, &b| p[a].abs().total_cmp(&p[b].abs()))
            .unwrap_or(0);
        let mut rows: Vec<f64> = Vec::with_capacity((dim - 1) * dim);
        for axis in (0..dim).filter(|&a| a != skip) {
            let mut v = vec![0.0; dim];
            v[axis] = 1.0;
            let along = dot(d, &v, p);
            for (x, q) in v.iter_mut().zip(p) {
                *x -= along * q;
            }
            for r in rows.chunks_exact(dim) {
                let c = dot(d, &v, r);
                for (x, q) in v.iter_mut().zip(r) {
                    *x -= c * q;
                }
            }
            normalize(d, &mut v);
            rows.extend_from_slice(&v);
        }
        Frame { dim, rows }
    }

    /// Number of tangent directions (n of S^n).
    pub(crate) fn n(&self) -> usize {
        self.dim - 1
    }

    /// The coordinates of the tangent vector `v` in this frame.
    pub(crate) fn coords(&self, v: &[f64], out: &mut [f64]) {
        let d = Dynamic(self.dim);
        for (o, r) in out.iter_mut().zip(self.rows.chunks_exact(self.dim)) {
            *o = dot(d, v, r);
        }
    }

    /// The tangent vector with coordinates `x` in this frame.
    pub(crate) fn vector(&self, x: &[f64], out: &mut [f64]) {
        out.iter_mut().for_each(|o| *o = 0.0);
        for (c, r) in x.iter().zip(self.rows.chunks_exact(self.dim)) {
            for (o, q) in out.iter_mut().zip(r) {
                *o += c * q;
            }
        }
    }

    /// Parallel transport of this frame at `a` along the great circle to `b` (each row by
    /// [`transport_vector`]). Rounding drift is removed by [`Frame::reorthonormalize`], which
    /// walks call every [`REORTHONORMALIZE_EVERY`] steps.
    pub(crate) fn transport(&mut self, a: &[f64], b: &[f64]) {
        let dim = self.dim;
        for r in self.rows.chunks_exact_mut(dim) {
            transport_vector(a, b, 1.0, r);
        }
    }

    /// Gram–Schmidt on the rows, after projecting them onto the tangent space at `p`.
    pub(crate) fn reorthonormalize(&mut self, p: &[f64]) {
        let dim = self.dim;
        let d = Dynamic(dim);
        for i in 0..self.n() {
            let (done, rest) = self.rows.split_at_mut(i * dim);
            let v = &mut rest[..dim];
            let along = dot(d, v, p);
            for (x, q) in v.iter_mut().zip(p) {
                *x -= along * q;
            }
            for w in done.chunks_exact(dim) {
                let c = dot(d, v, w);
                for (x, q) in v.iter_mut().zip(w) {
                    *x -= c * q;
                }
            }
            normalize(d, v);
        }
    }
}

/// Steps of a walk between two re-orthonormalisations of its frame.
pub(crate) const REORTHONORMALIZE_EVERY: usize = 16;

/// Parallel transport of the vector `v` tangent at `a` along the great circle towards `b` by
/// the fraction `s` of the arc, in place: `v + (u·v)((cos φ − 1) u − sin φ a)`, with `u` the
/// unit direction from `a` towards `b` and `φ = s θ(a, b)`; components orthogonal to the plane
/// of the arc are unchanged. A zero arc leaves `v` as it is.
pub(crate) fn transport_vector(a: &[f64], b: &[f64], s: f64, v: &mut [f64]) {
    let dim = a.len();
    let d = Dynamic(dim);
    let theta = Arc::between(d, a, b).theta;
    let (cos_t, sin_t) = (theta.cos(), theta.sin());
    if theta <= 0.0 || sin_t <= 0.0 {
        return;
    }
    // u = (b − cos θ a) / sin θ, without allocating.
    let uv = (dot(d, b, v) - cos_t * dot(d, a, v)) / sin_t;
    let phi = s * theta;
    let (c1, s1) = (phi.cos() - 1.0, phi.sin());
    for k in 0..dim {
        let u = (b[k] - cos_t * a[k]) / sin_t;
        v[k] += uv * (c1 * u - s1 * a[k]);
    }
}

/// A frame carried along the piecewise-geodesic path through `vertices`, one vertex at a time,
/// so that no walk stores a frame per vertex (n² numbers each on S^n).
pub(crate) struct Walk<'a> {
    vertices: &'a PointSet,
    frame: Frame,
    index: usize,
}

impl<'a> Walk<'a> {
    /// A walk at vertex 0, with [`Frame::at`] it.
    pub(crate) fn new(vertices: &'a PointSet) -> Walk<'a> {
        Walk {
            vertices,
            frame: Frame::at(vertices.get(0)),
            index: 0,
        }
    }

    /// The frame at the current vertex.
    pub(crate) fn frame(&self) -> &Frame {
        &self.frame
    }

    /// Moves the frame to the next vertex (no-op at the last).
    pub(crate) fn advance(&mut self) {
        let k = self.index;
        if k + 1 >= self.vertices.len() {
            return;
        }
        let (a, b) = (self.vertices.get(k), self.vertices.get(k + 1));
        self.frame.transport(a, b);
        self.index += 1;
        if self.index % REORTHONORMALIZE_EVERY == 0 {
            self.frame.reorthonormalize(b);
        }
    }

    /// Advances to vertex `k` (not behind the current one; at most the last vertex).
    pub(crate) fn advance_to(&mut self, k: usize) {
        let k = k.min(self.vertices.len() - 1);
        while self.index < k {
            self.advance();
        }
    }
}

/// The planar positions of the path through `vertices` rolled out onto R^n (n per vertex,
/// the first at the origin): each arc becomes a segment of its length, in the direction of
/// the arc in the transported frame.
pub(crate) fn develop(vertices: &PointSet) -> Vec<f64> {
    let dim = vertices.dim();
    let n = dim - 1;
    let d = Dynamic(dim);
    let m = vertices.len();
    let mut positions = vec![0.0; m * n];
    let mut walk = Walk::new(vertices);
    let mut step = vec![0.0; dim];
    let mut local = vec![0.0; n];
    for k in 1..m {
        log_into(d, vertices.get(k - 1), vertices.get(k), &mut step);
        walk.frame().coords(&step, &mut local);
        for c in 0..n {
            positions[k * n + c] = positions[(k - 1) * n + c] + local[c];
        }
        walk.advance();
    }
    positions
}

/// Wraps the planar point `x` back onto the sphere when the sphere is rolled to the fraction
/// `s` of the arc from `a` (frame `frame`, planar position `xa`) to `b` (planar position
/// `xb`): the contact point `c = slerp(a, b, s)` at planar position `x̄ = xa + s (xb − xa)`,
/// and `exp_c(P(F (x − x̄)))` with `P` the transport from `a` to `c`.
pub(crate) fn wrap(
    frame: &Frame,
    (a, b): (&[f64], &[f64]),
    (xa, xb): (&[f64], &[f64]),
    s: f64,
    x: &[f64],
) -> Vec<f64> {
    let dim = a.len();
    let n = dim - 1;
    let offset: Vec<f64> = (0..n)
        .map(|j| x[j] - (xa[j] + s * (xb[j] - xa[j])))
        .collect();
    let mut v = vec![0.0; dim];
    frame.vector(&offset, &mut v);
    let mut c = a.to_vec();
    if s > 0.0 {
        transport_vector(a, b, s, &mut v);
        let (w0, w1) = Arc::between(Dynamic(dim), a, b).weights(s);
        for k in 0..dim {
            c[k] = w0 * a[k] + w1 * b[k];
        }
        normalize(Dynamic(dim), &mut c);
    }
    exp_in_place(Dynamic(dim), &mut c, &v);
    c
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_frame_is_orthonormal_and_tangent() {
        let p = [0.6, 0.0, 0.8, 0.0];
        let f = Frame::at(&p);
        assert_eq!(f.n(), 3);
        for (i, r) in f.rows.chunks_exact(4).enumerate() {
            assert!(dot(Dynamic(4), r, &p).abs() < 1e-15);
            for (j, q) in f.rows.chunks_exact(4).enumerate() {
                let want = if i == j { 1.0 } else { 0.0 };
                assert!((dot(Dynamic(4), r, q) - want).abs() < 1e-14);
            }
        }
    }

    #[test]
    fn a_great_circle_develops_onto_a_straight_line_with_its_arc_lengths() {
        let rows: Vec<Vec<f64>> = (0..7)
            .map(|i| {
                let a = 0.3 * i as f64;
                vec![a.cos(), a.sin(), 0.0]
            })
            .collect();
        let x = develop(&PointSet::try_from_rows(&rows).unwrap());
        assert!(((x[12].powi(2) + x[13].powi(2)).sqrt() - 1.8).abs() < 1e-12);
        for k in 1..7 {
            // Collinear with the first step.
            assert!((x[2 * k] * x[3] - x[2 * k + 1] * x[2]).abs() < 1e-12);
        }
    }

    #[test]
    fn a_small_circle_develops_onto_a_circle_of_radius_tan_r() {
        // A circle of angular radius r has geodesic curvature cot r: rolled out, a circle of
        // radius tan r.
        let r = 0.5_f64;
        let m = 2000;
        let rows: Vec<Vec<f64>> = (0..m)
            .map(|i| {
                let a = 2.0 * std::f64::consts::PI * i as f64 / (m - 1) as f64;
                vec![r.sin() * a.cos(), r.sin() * a.sin(), r.cos()]
            })
            .collect();
        let x = develop(&PointSet::try_from_rows(&rows).unwrap());
        let p = |k: usize| (x[2 * k], x[2 * k + 1]);
        let (a, b, c) = (p(0), p(100), p(200));
        let ab = ((a.0 - b.0).powi(2) + (a.1 - b.1).powi(2)).sqrt();
        let bc = ((b.0 - c.0).powi(2) + (b.1 - c.1).powi(2)).sqrt();
        let ca = ((c.0 - a.0).powi(2) + (c.1 - a.1).powi(2)).sqrt();
        let area2 = ((b.0 - a.0) * (c.1 - a.1) - (b.1 - a.1) * (c.0 - a.0)).abs();
        let radius = ab * bc * ca / (2.0 * area2);
        assert!((radius - r.tan()).abs() < 1e-3, "{radius} vs {}", r.tan());
    }

    #[test]
    fn wrapping_a_vertex_or_a_chord_point_gives_the_path_back() {
        let rows = [
            vec![1.0, 0.0, 0.0],
            vec![0.8, 0.6, 0.0],
            vec![0.6, 0.6, (1.0f64 - 0.72).sqrt()],
        ];
        let pts = PointSet::try_from_rows(&rows).unwrap();
        let x = develop(&pts);
        let mut walk = Walk::new(&pts);
        for k in 0..2 {
            let (a, b) = (pts.get(k), pts.get(k + 1));
            let (xa, xb) = (&x[2 * k..2 * k + 2], &x[2 * k + 2..2 * k + 4]);
            let w = wrap(walk.frame(), (a, b), (xa, xb), 0.0, xa);
            assert!(angle_of(&w, a) < 1e-14);
            let mid: Vec<f64> = (0..2).map(|j| 0.5 * (xa[j] + xb[j])).collect();
            let w = wrap(walk.frame(), (a, b), (xa, xb), 0.5, &mid);
            let want = crate::sphere::geometry::point::slerp(a, b, 0.5).unwrap();
            assert!(angle_of(&w, &want) < 1e-14);
            walk.advance();
        }
    }

    fn angle_of(a: &[f64], b: &[f64]) -> f64 {
        crate::sphere::geometry::point::angle_between(a, b)
    }
}
