//! Areas of polygons on the sphere, in square metres: what a fitted polygon reports before and
//! after fitting (`area_m2`, `area_change`), per feature and in shared coverages alike.
//!
//! Each ring's solid angle is summed as a fan of triangles from the ring's mean direction (Van
//! Oosterom and Strackee's formula), so the area does not depend on how longitudes wrap: a ring
//! across the antimeridian or around a pole (input, rejoined) and its pieces cut at ±180
//! (output) measure the same. geo's lon/lat area algorithms handle neither.

use crate::earth::lonlat::{lonlat_to_unit, EARTH_RADIUS_M};

/// Area of the region a ring of unit vectors bounds on the side of its mean direction, square
/// metres. The ring may be given closed (last = first) or open; fewer than 3 points bound none.
pub fn ring_area_m2(ring: &[[f64; 3]]) -> f64 {
    if ring.len() < 3 {
        return 0.0;
    }
    let mut c = [0.0f64; 3];
    for p in ring {
        for k in 0..3 {
            c[k] += p[k];
        }
    }
    let n = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
    if n == 0.0 {
        return 0.0;
    }
    let c = [c[0] / n, c[1] / n, c[2] / n];
    let dot = |a: &[f64; 3], b: &[f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let closing = (ring.first() != ring.last()).then(|| [ring[ring.len() - 1], ring[0]]);
    let mut omega = 0.0;
    for w in ring.windows(2).chain(closing.as_ref().map(|w| &w[..])) {
        let (a, b) = (&w[0], &w[1]);
        let x = [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ];
        let num = dot(&c, &x);
        let den = 1.0 + dot(&c, a) + dot(a, b) + dot(b, &c);
        omega += 2.0 * num.atan2(den);
    }
    omega.abs() * EARTH_RADIUS_M * EARTH_RADIUS_M
}

/// Area of one polygon given as rings of unit vectors (the exterior first, then its holes).
pub fn polygon_area_m2<R: AsRef<[[f64; 3]]>>(rings: &[R]) -> f64 {
    match rings.split_first() {
        Some((exterior, holes)) => {
            ring_area_m2(exterior.as_ref())
                - holes.iter().map(|h| ring_area_m2(h.as_ref())).sum::<f64>()
        }
        None => 0.0,
    }
}

/// Area of lon/lat polygons (each a list of rings of `[lon, lat]`, exterior first).
pub fn lonlat_polygons_area_m2(polygons: &[Vec<Vec<[f64; 2]>>]) -> f64 {
    polygons
        .iter()
        .map(|p| {
            let rings: Vec<Vec<[f64; 3]>> = p
                .iter()
                .map(|r| r.iter().map(|q| lonlat_to_unit(q[0], q[1])).collect())
                .collect();
            polygon_area_m2(&rings)
        })
        .sum()
}

/// The relative change from `before` to `after` (0 when there was no area before).
pub fn area_change(before_m2: f64, after_m2: f64) -> f64 {
    if before_m2 > 0.0 {
        after_m2 / before_m2 - 1.0
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    fn circle(lat_deg: f64, n: usize, lon0: f64) -> Vec<[f64; 3]> {
        (0..=n)
            .map(|i| lonlat_to_unit(lon0 + 360.0 * i as f64 / n as f64 - 180.0, lat_deg))
            .collect()
    }

    #[test]
    fn a_polar_cap_measures_its_spherical_cap() {
        // The cap above 60 N has area 2 pi R^2 (1 - sin 60); a fine polygon of great-circle
        // edges is slightly smaller.
        let cap = 2.0 * PI * EARTH_RADIUS_M * EARTH_RADIUS_M * (1.0 - 60f64.to_radians().sin());
        let a = ring_area_m2(&circle(60.0, 3600, 0.0));
        assert!((a / cap - 1.0).abs() < 1e-4, "{a} against {cap}");
        // Open or closed, either orientation: the same area.
        let mut open = circle(60.0, 3600, 0.0);
        open.pop();
        open.reverse();
        assert!((ring_area_m2(&open) / a - 1.0).abs() < 1e-12);
    }

    #[test]
    fn a_square_across_the_antimeridian_measures_as_its_copy_at_zero() {
        let sq = |lon0: f64| -> Vec<Vec<[f64; 2]>> {
            let w = |x: f64| if x > 180.0 { x - 360.0 } else { x };
            vec![vec![
                [w(lon0 - 5.0), -5.0],
                [w(lon0 + 5.0), -5.0],
                [w(lon0 + 5.0), 5.0],
                [w(lon0 - 5.0), 5.0],
                [w(lon0 - 5.0), -5.0],
            ]]
        };
        let here = lonlat_polygons_area_m2(&[sq(0.0)]);
        let there = lonlat_polygons_area_m2(&[sq(180.0)]);
        assert!(here > 1.2e12 && here < 1.3e12, "{here}");
        assert!((here / there - 1.0).abs() < 1e-9, "{here} {there}");
    }

    #[test]
    fn holes_are_taken_away() {
        let outer = circle(60.0, 360, 0.0);
        let hole = circle(80.0, 360, 0.0);
        let a = polygon_area_m2(&[outer.clone(), hole.clone()]);
        assert!((a - (ring_area_m2(&outer) - ring_area_m2(&hole))).abs() < 1.0);
        assert_eq!(area_change(0.0, 5.0), 0.0);
        assert!((area_change(2.0, 3.0) - 0.5).abs() < 1e-15);
    }
}
