//! Crossings of great-circle segments on S^2: whether two short arcs of great circles cross,
//! and the crossings between (and within) polylines, found with box pruning.
//!
//! Two segments `a-b` and `c-d` (each shorter than a half turn) cross when `c` and `d` lie on
//! opposite sides of the great circle through `a`, `b` (the signs of `(a × b) · c` and
//! `(a × b) · d` differ, strictly), `a` and `b` on opposite sides of the one through `c`, `d`,
//! and the two segments are on the same side of the sphere (`(a + b) · (c + d) > 0`), so the
//! crossing is the one near them, not its antipode. Touching (an end on the other segment, a
//! shared end) is not crossing.

/// `a × b`.
fn cross(a: &[f64; 3], b: &[f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn dot(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// True when the great-circle segments `a-b` and `c-d` cross (see the module docs).
pub fn segments_cross(a: &[f64; 3], b: &[f64; 3], c: &[f64; 3], d: &[f64; 3]) -> bool {
    let n1 = cross(a, b);
    let (sc, sd) = (dot(&n1, c), dot(&n1, d));
    if !((sc > 0.0 && sd < 0.0) || (sc < 0.0 && sd > 0.0)) {
        return false;
    }
    let n2 = cross(c, d);
    let (sa, sb) = (dot(&n2, a), dot(&n2, b));
    if !((sa > 0.0 && sb < 0.0) || (sa < 0.0 && sb > 0.0)) {
        return false;
    }
    let m1 = [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
    let m2 = [c[0] + d[0], c[1] + d[1], c[2] + d[2]];
    dot(&m1, &m2) > 0.0
}

/// An axis-aligned box around points of R^3 (a great-circle segment shorter than a quarter
/// turn bulges out of its chord's box by at most its sagitta, added as a margin).
#[derive(Clone, Copy, Debug)]
struct Box3 {
    lo: [f64; 3],
    hi: [f64; 3],
}

impl Box3 {
    fn of(points: &[[f64; 3]]) -> Box3 {
        let mut b = Box3 {
            lo: [f64::INFINITY; 3],
            hi: [f64::NEG_INFINITY; 3],
        };
        for p in points {
            for k in 0..3 {
                b.lo[k] = b.lo[k].min(p[k]);
                b.hi[k] = b.hi[k].max(p[k]);
            }
        }
        b
    }

    fn grown(mut self, m: f64) -> Box3 {
        for k in 0..3 {
            self.lo[k] -= m;
            self.hi[k] += m;
        }
        self
    }

    fn meets(&self, o: &Box3) -> bool {
        (0..3).all(|k| self.lo[k] <= o.hi[k] && o.lo[k] <= self.hi[k])
    }
}

/// Margin for a segment's box: its sagitta, 1 − cos(θ/2) ≤ θ²/8 with θ ≤ the chord · π/2.
fn sagitta(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    let c2 = (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2);
    0.31 * c2 + 1e-15
}

/// Whether two polylines (unit vectors) cross anywhere; with `same`, whether one polyline
/// crosses itself (neighbouring segments, which share a vertex, never count).
pub fn polylines_cross(p: &[[f64; 3]], q: &[[f64; 3]], same: bool) -> bool {
    if p.len() < 2 || q.len() < 2 {
        return false;
    }
    let bp = Box3::of(p).grown(0.1);
    let bq = Box3::of(q).grown(0.1);
    if !bp.meets(&bq) {
        return false;
    }
    let seg_box = |a: &[f64; 3], b: &[f64; 3]| Box3::of(&[*a, *b]).grown(sagitta(a, b));
    let qboxes: Vec<Box3> = q.windows(2).map(|w| seg_box(&w[0], &w[1])).collect();
    for (i, w) in p.windows(2).enumerate() {
        let bi = seg_box(&w[0], &w[1]);
        if !bi.meets(&bq) {
            continue;
        }
        let start = if same { i + 2 } else { 0 };
        for j in start..qboxes.len() {
            let (c, d) = (&q[j], &q[j + 1]);
            // Segments that share an end touch there (ends at a junction, a ring's seam).
            if w[0] == *c || w[0] == *d || w[1] == *c || w[1] == *d {
                continue;
            }
            if bi.meets(&qboxes[j]) && segments_cross(&w[0], &w[1], c, d) {
                return true;
            }
        }
    }
    false
}

#[cfg(test)]
mod tests {
    use super::*;

    fn u(lon: f64, lat: f64) -> [f64; 3] {
        let (lo, la) = (lon.to_radians(), lat.to_radians());
        [la.cos() * lo.cos(), la.cos() * lo.sin(), la.sin()]
    }

    #[test]
    fn crossing_touching_and_antipodal_segments() {
        assert!(segments_cross(
            &u(0.0, -1.0),
            &u(0.0, 1.0),
            &u(-1.0, 0.0),
            &u(1.0, 0.0)
        ));
        // Touching at an end, or sharing one, is not crossing.
        assert!(!segments_cross(
            &u(0.0, -1.0),
            &u(0.0, 1.0),
            &u(0.0, 0.0),
            &u(1.0, 0.0)
        ));
        assert!(!segments_cross(
            &u(0.0, 0.0),
            &u(0.0, 1.0),
            &u(0.0, 0.0),
            &u(1.0, 0.0)
        ));
        // The antipodal copy of a crossing segment does not cross.
        assert!(!segments_cross(
            &u(0.0, -1.0),
            &u(0.0, 1.0),
            &u(179.0, 0.0),
            &u(-179.0, 0.0)
        ));
        // Disjoint.
        assert!(!segments_cross(
            &u(0.0, 0.0),
            &u(1.0, 0.0),
            &u(0.0, 1.0),
            &u(1.0, 1.0)
        ));
        // Across the antimeridian, where lon/lat would wrap.
        assert!(segments_cross(
            &u(179.5, 0.0),
            &u(-179.5, 0.0),
            &u(180.0, -1.0),
            &u(180.0, 1.0)
        ));
    }

    #[test]
    fn polylines_and_self_crossings() {
        let zig: Vec<[f64; 3]> = [(0.0, 0.0), (1.0, 0.0), (0.5, 1.0), (0.5, -1.0)]
            .iter()
            .map(|&(a, b)| u(a, b))
            .collect();
        assert!(polylines_cross(&zig, &zig, true));
        let straight: Vec<[f64; 3]> = (0..10).map(|i| u(i as f64 * 0.1, 0.0)).collect();
        assert!(!polylines_cross(&straight, &straight, true));
        let other: Vec<[f64; 3]> = (0..10).map(|i| u(0.55, -0.45 + i as f64 * 0.1)).collect();
        assert!(polylines_cross(&straight, &other, false));
        let apart: Vec<[f64; 3]> = (0..10).map(|i| u(5.0, -0.5 + i as f64 * 0.1)).collect();
        assert!(!polylines_cross(&straight, &apart, false));
    }
}
