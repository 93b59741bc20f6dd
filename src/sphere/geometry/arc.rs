//! Minor great-circle arcs on S^n and the distance of a point to one: the cross-track distance
//! when the foot of the perpendicular falls on the arc, else the distance to the nearer end.
//! `ArcFrame` prepares an arc for many queries; Douglas–Peucker, the optimal subset, the
//! tolerance fitter's polyline removals and every bound in `certify/` measure with it.

use crate::sphere::geometry::point::{
    angle, angle_from_sine, diff_sq, dot, normalize, Arc, Dim, ANTIPODAL_MARGIN_RAD,
};

/// Arcs shorter than this are treated as a point: the plane they span is undefined to rounding
/// (the direction of `b − (a·b) a` has relative error ~1e-16 / θ, which is 1e-4 here; below it
/// the distance to the end point differs from the distance to the arc by less than 1e-12 rad).
const DEGENERATE_ARC_RAD: f64 = 1e-12;

/// A minor great-circle arc prepared for many distance queries: `e1 = a`, `e2` the unit tangent
/// at `a` towards `b`, and the arc's angle.
pub(crate) struct ArcFrame {
    pub(crate) e1: Coords,
    pub(crate) e2: Coords,
    b: Coords,
    pub(crate) theta: f64,
    /// cos and sin of `theta`: whether a point projects inside the arc, without an atan2.
    cos_theta: f64,
    sin_theta: f64,
    /// The end points are (nearly) antipodal: the minor arc is undefined.
    antipodal: bool,
}

/// A point's coordinates, inline up to 4 (S^3), on the heap beyond: frames are built by the
/// hundred thousand (one per Douglas–Peucker split, per removal tried, per two-way piece), and
/// three allocations each were a tenth of a coastline's fitting time.
#[derive(Clone, Debug)]
pub(crate) enum Coords {
    Inline([f64; 4], usize),
    Heap(Vec<f64>),
}

impl Coords {
    fn from_slice(x: &[f64]) -> Coords {
        if x.len() <= 4 {
            let mut a = [0.0; 4];
            a[..x.len()].copy_from_slice(x);
            Coords::Inline(a, x.len())
        } else {
            Coords::Heap(x.to_vec())
        }
    }
}

impl std::ops::Deref for Coords {
    type Target = [f64];
    #[inline(always)]
    fn deref(&self) -> &[f64] {
        match self {
            Coords::Inline(a, n) => &a[..*n],
            Coords::Heap(v) => v,
        }
    }
}

impl std::ops::DerefMut for Coords {
    #[inline(always)]
    fn deref_mut(&mut self) -> &mut [f64] {
        match self {
            Coords::Inline(a, n) => &mut a[..*n],
            Coords::Heap(v) => v,
        }
    }
}

impl ArcFrame {
    /// sin of the arc's angle.
    pub(crate) fn sin_theta(&self) -> f64 {
        self.sin_theta
    }

    /// cos of the arc's angle.
    pub(crate) fn cos_theta(&self) -> f64 {
        self.cos_theta
    }

    /// The end points are (nearly) antipodal: the minor arc is undefined.
    pub(crate) fn is_antipodal(&self) -> bool {
        self.antipodal
    }

    /// The arc has (next to) no length: distances are to its start point.
    pub(crate) fn degenerate(&self) -> bool {
        self.theta < DEGENERATE_ARC_RAD
    }

    /// [`distance_to_arc`] for this arc, in the runtime dimension.
    pub(crate) fn distance_dyn(&self, q: &[f64]) -> f64 {
        let d = crate::sphere::geometry::point::Dynamic(self.e1.len());
        if self.antipodal {
            angle(d, q, &self.e1).min(angle(d, q, &self.b))
        } else {
            self.distance(d, q)
        }
    }

    pub(crate) fn new<D: Dim>(d: D, a: &[f64], b: &[f64]) -> ArcFrame {
        let dim = d.get();
        let arc = Arc::between(d, a, b);
        let theta = arc.theta;
        let cos = dot(d, a, b);
        let mut e2 = Coords::from_slice(&b[..dim]);
        for k in 0..dim {
            e2[k] -= cos * a[k];
        }
        if theta >= DEGENERATE_ARC_RAD {
            normalize(d, &mut e2);
        }
        ArcFrame {
            e1: Coords::from_slice(&a[..dim]),
            e2,
            b: Coords::from_slice(&b[..dim]),
            theta,
            cos_theta: arc.cos_theta,
            sin_theta: arc.sin_theta,
            antipodal: theta > std::f64::consts::PI - ANTIPODAL_MARGIN_RAD,
        }
    }

    #[inline(always)]
    pub(crate) fn distance<D: Dim>(&self, d: D, q: &[f64]) -> f64 {
        if self.theta < DEGENERATE_ARC_RAD {
            return angle(d, q, &self.e1);
        }
        let (e1, e2) = (&self.e1[..d.get()], &self.e2[..d.get()]);
        let x = dot(d, q, e1);
        let y = dot(d, q, e2);
        self.distance_in_plane(d, q, x, y)
    }

    /// [`distance_key`] of [`ArcFrame::distance`]: the squared sine of the cross-track angle
    /// where the foot is on the arc (|q − x e1 − y e2|², the angle being at most a quarter
    /// turn), else the key of the nearer end from its squared chord. Not for an antipodal arc.
    #[inline(always)]
    pub(crate) fn distance_key<D: Dim>(&self, d: D, q: &[f64]) -> f64 {
        if self.theta < DEGENERATE_ARC_RAD {
            return chord_key(diff_sq(d, q, &self.e1));
        }
        let (e1, e2) = (&self.e1[..d.get()], &self.e2[..d.get()]);
        let x = dot(d, q, e1);
        let y = dot(d, q, e2);
        self.distance_key_in_plane(d, q, x, y)
    }

    /// [`ArcFrame::distance_key`] given `x = q . e1`, `y = q . e2`. Not for a degenerate arc.
    #[inline(always)]
    pub(crate) fn distance_key_in_plane<D: Dim>(&self, d: D, q: &[f64], x: f64, y: f64) -> f64 {
        match self.cross_track_sq(d, q, x, y) {
            Some(perp_sq) => perp_sq,
            None => chord_key(diff_sq(d, q, &self.e1)).min(chord_key(diff_sq(d, q, &self.b))),
        }
    }

    /// The squared sine of `q`'s cross-track angle when its projection on the great circle
    /// lies within the arc (its angle from a, atan2(y, x), in [0, theta]: y >= 0 and
    /// sin(phi − theta) <= 0), else `None`. Computed as |q − proj|² directly (not as
    /// 1 − |proj|², which loses half the digits for points near the circle).
    #[inline(always)]
    fn cross_track_sq<D: Dim>(&self, d: D, q: &[f64], x: f64, y: f64) -> Option<f64> {
        if !(y >= 0.0 && y * self.cos_theta <= x * self.sin_theta) {
            return None;
        }
        let (e1, e2) = (&self.e1[..d.get()], &self.e2[..d.get()]);
        let mut perp_sq = 0.0;
        for k in 0..d.get() {
            let r = q[k] - x * e1[k] - y * e2[k];
            perp_sq += r * r;
        }
        Some(perp_sq)
    }

    /// [`ArcFrame::distance`] of `q` given its coordinates `x = q . e1`, `y = q . e2` in the
    /// arc's plane (for a caller that needs them too). Not for a degenerate arc.
    #[inline(always)]
    pub(crate) fn distance_in_plane<D: Dim>(&self, d: D, q: &[f64], x: f64, y: f64) -> f64 {
        match self.cross_track_sq(d, q, x, y) {
            Some(perp_sq) => {
                // The sine of the cross-track angle.
                let perp = perp_sq.sqrt();
                if perp <= 0.1 {
                    angle_from_sine(perp)
                } else {
                    perp.atan2(x.hypot(y))
                }
            }
            None => angle(d, q, &self.e1).min(angle(d, q, &self.b)),
        }
    }
}

/// Geodesic distance (radians) from unit vector `q` to the minor great-circle arc from `a` to
/// `b`: the cross-track distance when the foot of the perpendicular lies on the arc, otherwise
/// the distance to the nearer end point. When `a` and `b` coincide it is the distance to `a`.
/// (Nearly) antipodal `a`, `b` have no minor arc; the result is then the distance to the nearer
/// end point, an upper bound of the distance to any arc joining them.
///
/// # Panics
/// If the slices differ in length.
///
/// # Example
/// ```
/// use spherefit::sphere::geometry::arc::distance_to_arc;
/// let (a, b) = ([1.0, 0.0, 0.0], [0.0, 1.0, 0.0]);
/// let h = 0.1_f64;
/// let q = [h.cos() * 0.5_f64.sqrt(), h.cos() * 0.5_f64.sqrt(), h.sin()];
/// assert!((distance_to_arc(&q, &a, &b) - 0.1).abs() < 1e-15);
/// ```
pub fn distance_to_arc(q: &[f64], a: &[f64], b: &[f64]) -> f64 {
    assert!(q.len() == a.len() && a.len() == b.len(), "one dimension");
    crate::with_dim!(q.len(), |d| {
        let frame = ArcFrame::new(d, a, b);
        if frame.antipodal {
            angle(d, q, a).min(angle(d, q, b))
        } else {
            frame.distance(d, q)
        }
    })
}

/// A number that orders distances as the distances do: sin² d up to a quarter turn, 2 − sin² d
/// past it (infinite from a half turn on). Douglas–Peucker only compares distances, with each
/// other and with the tolerance, and the key of a point's distance to an arc needs no square
/// root, arcsine or arctangent (see [`ArcFrame::distance_key`]): they were a third of its time.
pub(crate) fn distance_key(angle_rad: f64) -> f64 {
    if angle_rad >= std::f64::consts::PI {
        return f64::INFINITY;
    }
    let s = angle_rad.sin();
    if angle_rad <= std::f64::consts::FRAC_PI_2 {
        s * s
    } else {
        2.0 - s * s
    }
}

/// [`distance_key`] of the angle between two unit vectors from their squared chord
/// c² = 4 sin²(d/2): sin² d = c² (1 − c²/4), and past a quarter turn (c² > 2) 2 minus that.
#[inline(always)]
pub(crate) fn chord_key(c2: f64) -> f64 {
    let s2 = c2 * (1.0 - 0.25 * c2);
    if c2 <= 2.0 {
        s2
    } else {
        2.0 - s2
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use approx::assert_relative_eq;

    /// The unit vector at longitude `lon` and latitude `lat` (radians).
    pub(crate) fn on_equator(lon: f64, lat: f64) -> [f64; 3] {
        [lat.cos() * lon.cos(), lat.cos() * lon.sin(), lat.sin()]
    }

    #[test]
    fn cross_track_inside_and_beyond_the_arc() {
        let (a, b) = (on_equator(0.0, 0.0), on_equator(0.5, 0.0));
        // Inside: the distance is the latitude.
        for lat in [1e-9, 1e-5, 0.01, -0.3, 1.2] {
            let q = on_equator(0.2, lat);
            assert_relative_eq!(distance_to_arc(&q, &a, &b), lat.abs(), max_relative = 1e-12);
        }
        // Beyond b and before a: the distance to the end point, not to the great circle.
        let q = on_equator(0.7, 0.01);
        let expected = angle(crate::sphere::geometry::point::Fixed::<3>, &q, &b);
        assert_relative_eq!(distance_to_arc(&q, &a, &b), expected, max_relative = 1e-14);
        assert!(expected > 0.2);
        let q = on_equator(-0.1, 0.0);
        assert_relative_eq!(distance_to_arc(&q, &a, &b), 0.1, max_relative = 1e-14);
        // A degenerate arc is its point.
        let q = on_equator(0.3, 0.4);
        let expected = angle(crate::sphere::geometry::point::Fixed::<3>, &q, &a);
        assert_relative_eq!(distance_to_arc(&q, &a, &a), expected, max_relative = 1e-14);
    }

    #[test]
    fn cross_track_on_s3_matches_an_embedded_s2() {
        let (a, b, q) = (
            on_equator(0.1, 0.0),
            on_equator(0.9, 0.0),
            on_equator(0.4, 0.2),
        );
        let lift = |v: [f64; 3]| [v[0], 0.0, v[1], v[2]];
        assert_relative_eq!(
            distance_to_arc(&lift(q), &lift(a), &lift(b)),
            distance_to_arc(&q, &a, &b),
            max_relative = 1e-14
        );
    }
}
