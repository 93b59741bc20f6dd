//! Lon/lat output of curves on the sphere: lines cut at the antimeridian and polygons split
//! there, as RFC 7946 section 3.1.9 asks.
//!
//! On the sphere nothing is special at ±180 degrees or at the poles: curves are fitted and
//! sampled as unit vectors. Only the conversion back to lon/lat needs care:
//!
//! * [`cut_line`]: a polyline whose segment crosses the antimeridian (the half-plane `y = 0,
//!   x < 0`) is cut there; the crossing latitude is where the great-circle segment meets the
//!   antimeridian, and both pieces get that vertex (at +180 on one side, -180 on the other). A
//!   segment passing a pole on the prime-meridian side, whose longitudes are more than 180
//!   degrees apart, gets its lon = 0 crossing inserted. So no output segment spans more than 180
//!   degrees of longitude.
//! * [`split_polygon`] ([`split`]): polygons cut at ±180 where their great-circle edges
//!   cross it and rings around a pole closed along it, without moving or dropping a vertex;
//!   one splitter for per-feature and shared fitting.
//! * [`rejoin::rejoin_cut_polygons`]: input already cut that way (parts touching ±180, polar
//!   caps closed along the meridian and the pole) joined back into rings on the sphere before
//!   fitting, so the cut is never fitted as if it were outline.
//!
//! Positions are `[lon_deg, lat_deg, alt]`; the altitude is interpolated at new vertices and
//! ignored by callers that have none.

pub mod rejoin;
pub mod split;

pub use split::{split_polygon, split_polygon_around};

use crate::earth::lonlat::unit_to_lonlat;
use crate::sphere::geometry::point::angle_between;

/// A position `[lon_deg, lat_deg, altitude]` (the altitude is meaningless when the data have
/// none).
pub type Position = [f64; 3];

fn side(y: f64) -> i8 {
    if y > 0.0 {
        1
    } else if y < 0.0 {
        -1
    } else {
        0
    }
}

fn normalize3(v: [f64; 3]) -> [f64; 3] {
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    if n == 0.0 {
        v
    } else {
        [v[0] / n, v[1] / n, v[2] / n]
    }
}

/// Where the great-circle segment `a -> b` meets the plane `y = 0`, for `a.y` and `b.y` of
/// opposite signs, and the fraction of the segment's length at which it does.
fn y_crossing(a: &[f64; 3], b: &[f64; 3]) -> ([f64; 3], f64) {
    let (wa, wb) = (b[1].abs(), a[1].abs());
    let mut c = normalize3([wa * a[0] + wb * b[0], 0.0, wa * a[2] + wb * b[2]]);
    c[1] = 0.0;
    let total = angle_between(a, b);
    let f = if total > 0.0 {
        (angle_between(a, &c) / total).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (c, f)
}

fn lat_of(c: &[f64; 3]) -> f64 {
    c[2].atan2(c[0].hypot(c[1])).to_degrees().clamp(-90.0, 90.0)
}

/// Converts a polyline of unit vectors (with an altitude per vertex, or zeros) to lon/lat
/// pieces cut at the antimeridian. Returns at least one piece for non-empty input.
pub fn cut_line(points: &[[f64; 3]], alts: &[f64]) -> Vec<Vec<Position>> {
    debug_assert_eq!(points.len(), alts.len());
    let mut parts: Vec<Vec<Position>> = Vec::new();
    let mut current: Vec<Position> = Vec::with_capacity(points.len());
    // Sign of y of the current piece (0 until a point off the plane y = 0 is seen).
    let mut piece_side: i8 = 0;
    // Side of the first point off the plane after each index (1 when there is none), from one
    // backward pass: a curve that runs along the antimeridian stays linear in time.
    let mut next_side = vec![1i8; points.len()];
    let mut s = 1;
    for i in (0..points.len()).rev() {
        next_side[i] = s;
        if side(points[i][1]) != 0 {
            s = side(points[i][1]);
        }
    }
    for i in 0..points.len() {
        let b = &points[i];
        let sb = side(b[1]);
        if i > 0 {
            let a = &points[i - 1];
            let sa = side(a[1]);
            if sa != 0 && sb != 0 && sa != sb {
                let (c, f) = y_crossing(a, b);
                let alt = alts[i - 1] + f * (alts[i] - alts[i - 1]);
                if c[0] < 0.0 {
                    let lon_end = if sa > 0 { 180.0 } else { -180.0 };
                    let lat = lat_of(&c);
                    current.push([lon_end, lat, alt]);
                    parts.push(std::mem::take(&mut current));
                    current.push([-lon_end, lat, alt]);
                    piece_side = sb;
                } else {
                    let (lon_a, _) = unit_to_lonlat(a);
                    let (lon_b, _) = unit_to_lonlat(b);
                    if (lon_a - lon_b).abs() > 180.0 {
                        current.push([0.0, lat_of(&c), alt]);
                    }
                }
            } else if sa == 0 && sb != 0 && piece_side != 0 && sb != piece_side && a[0] < 0.0 {
                // The line touched the antimeridian at `a` and now continues on the other side.
                let last = *current.last().expect("a was pushed");
                parts.push(std::mem::take(&mut current));
                current.push([-last[0], last[1], last[2]]);
            }
        }
        if sb != 0 {
            piece_side = sb;
        }
        let (mut lon, lat) = unit_to_lonlat(b);
        if sb == 0 && b[0] < 0.0 {
            // On the antimeridian: take the side of the piece, or of the next point off it.
            let s = if piece_side != 0 {
                piece_side
            } else {
                next_side[i]
            };
            lon = 180.0 * f64::from(s);
        }
        current.push([lon, lat, alts[i]]);
    }
    if !current.is_empty() {
        parts.push(current);
    }
    parts
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::earth::lonlat::lonlat_to_unit;
    use proptest::prelude::*;

    fn line(lonlats: &[(f64, f64)]) -> Vec<Vec<Position>> {
        let pts: Vec<[f64; 3]> = lonlats.iter().map(|&(a, b)| lonlat_to_unit(a, b)).collect();
        cut_line(&pts, &vec![0.0; pts.len()])
    }

    fn max_step(parts: &[Vec<Position>]) -> f64 {
        parts
            .iter()
            .flat_map(|p| p.windows(2).map(|w| (w[1][0] - w[0][0]).abs()))
            .fold(0.0, f64::max)
    }

    #[test]
    fn crossing_is_cut_at_the_great_circle_latitude() {
        let parts = line(&[(179.0, 10.0), (-179.0, 10.0)]);
        assert_eq!(parts.len(), 2);
        let end = parts[0].last().unwrap();
        let start = parts[1][0];
        assert_eq!(end[0], 180.0);
        assert_eq!(start[0], -180.0);
        assert_eq!(end[1], start[1]);
        // The great circle through two points at 10 N bulges slightly poleward.
        assert!(end[1] > 10.0 && end[1] < 10.01, "{}", end[1]);
    }

    #[test]
    fn westward_crossing_is_cut_too() {
        let parts = line(&[(-170.0, 0.0), (170.0, 1.0), (160.0, 1.0)]);
        assert_eq!(parts.len(), 2);
        assert_eq!(parts[0].last().unwrap()[0], -180.0);
        assert_eq!(parts[1][0][0], 180.0);
        assert_eq!(parts[1].len(), 3);
    }

    #[test]
    fn prime_meridian_is_not_cut() {
        let parts = line(&[(-1.0, 0.0), (1.0, 0.0)]);
        assert_eq!(parts.len(), 1);
        assert_eq!(parts[0].len(), 2);
    }

    #[test]
    fn passing_a_pole_keeps_segments_under_180_degrees() {
        // Over the North Pole on the prime-meridian side: lon jumps from 170 to -9.5.
        let parts = line(&[(170.0, 89.9), (-9.5, 89.9)]);
        assert_eq!(parts.len(), 1);
        assert!(max_step(&parts) <= 180.0, "{:?}", parts);
        // Over the pole on the antimeridian side: cut.
        let parts = line(&[(10.0, 89.9), (-170.5, 89.9)]);
        assert_eq!(parts.len(), 2);
        assert!(max_step(&parts) <= 180.0, "{:?}", parts);
    }

    #[test]
    fn touching_the_antimeridian_and_turning_back_is_one_piece() {
        let parts = line(&[(170.0, 0.0), (180.0, 1.0), (170.0, 2.0)]);
        assert_eq!(parts.len(), 1);
        assert_eq!(parts[0][1][0], 180.0);
        let parts = line(&[(-170.0, 0.0), (180.0, 1.0), (-170.0, 2.0)]);
        assert_eq!(parts.len(), 1);
        assert_eq!(parts[0][1][0], -180.0);
    }

    #[test]
    fn passing_through_a_vertex_on_the_antimeridian_cuts_there() {
        let parts = line(&[(170.0, 0.0), (180.0, 1.0), (-170.0, 2.0)]);
        assert_eq!(parts.len(), 2);
        assert_eq!(parts[0].last().unwrap()[0], 180.0);
        assert_eq!(parts[1][0][0], -180.0);
        assert_eq!(parts[1][0][1], parts[0].last().unwrap()[1]);
    }

    #[test]
    fn altitude_is_interpolated_at_the_cut() {
        let pts = [lonlat_to_unit(179.0, 0.0), lonlat_to_unit(-179.0, 0.0)];
        let parts = cut_line(&pts, &[100.0, 200.0]);
        assert!((parts[0][1][2] - 150.0).abs() < 1e-6);
        assert!((parts[1][0][2] - 150.0).abs() < 1e-6);
    }

    proptest! {
        #[test]
        fn no_output_segment_spans_more_than_180_degrees(
            lon0 in -180.0f64..180.0, lat0 in -89.0f64..89.0,
            steps in proptest::collection::vec((-3.0f64..3.0, -3.0f64..3.0), 1..60),
        ) {
            let mut pts = vec![lonlat_to_unit(lon0, lat0)];
            let (mut lon, mut lat) = (lon0, lat0);
            for (dlon, dlat) in steps {
                lon = (lon + dlon + 540.0).rem_euclid(360.0) - 180.0;
                lat = (lat + dlat).clamp(-90.0, 90.0);
                pts.push(lonlat_to_unit(lon, lat));
            }
            let parts = cut_line(&pts, &vec![0.0; pts.len()]);
            prop_assert!(max_step(&parts) <= 180.0 + 1e-9);
            for p in &parts {
                for q in p {
                    prop_assert!((-180.0..=180.0).contains(&q[0]));
                }
            }
        }
    }
}
