//! Polygons on the sphere written as lon/lat polygons within [-180, 180] (RFC 7946 §3.1.9),
//! for per-feature and shared fitting alike.
//!
//! A ring is a closed curve on the sphere; in lon/lat it may step across ±180 or wind around a
//! pole. [`split_polygon`] writes it without moving or dropping a vertex:
//!
//! 1. Longitudes are unwrapped (each step the short way round) and every step across an odd
//!    multiple of 180 gets a vertex where its *great circle* meets the antimeridian, so the cut
//!    lies on the curve, not on the straight lon/lat chord.
//! 2. A ring that winds once around a pole is turned to start at such a crossing, so it spans
//!    exactly [-180, 180], and is closed along the meridian and the pole (the pole on its
//!    smaller side, whichever way it turns; input cut along a pole keeps that pole), as GDAL
//!    and the `antimeridian` package write polar caps.
//! 3. Rings are oriented (exterior counter-clockwise, holes clockwise: the interior is on the
//!    left of every edge) and cut into the strips [180 (2k - 1), 180 (2k + 1)]. In each strip
//!    the pieces of the rings are chains from one cut line to another; a chain that ends on
//!    the east line continues north along it to the next chain that starts there, one ending
//!    on the west line continues south (the interior stays on the left). That joins the pieces
//!    into simple rings even when a ring crosses the line many times, where clipping each ring
//!    alone (Sutherland–Hodgman) joins them by zero-width bridges. Rings that lie inside one
//!    strip stay whole; holes go to the exterior that contains them.
//!
//! No boolean-operation library is used: the cut lines pass through inserted vertices, so the
//! only new coordinates are the crossings (on the great circle) and the pole corners, and no
//! vertex of the curve is snapped or dropped as collinear (a planar clip drops vertices along a
//! parallel, which on the sphere are not collinear at all).

use crate::earth::lonlat::lonlat_to_unit;
use crate::earth::polygon::antimeridian::Position;
use crate::sphere::geometry::point::angle_between;

/// Latitude where the great-circle step `q -> p` (lon/lat, taken the short way) meets the
/// antimeridian, and the fraction of the step's length at which it does (for the altitude).
fn crossing(q: &Position, p: &Position) -> (f64, f64) {
    let (a, b) = (lonlat_to_unit(q[0], q[1]), lonlat_to_unit(p[0], p[1]));
    // The point of the great circle with y = 0 between a and b (their y have opposite signs).
    let (wa, wb) = (b[1].abs(), a[1].abs());
    let (x, z) = (wa * a[0] + wb * b[0], wa * a[2] + wb * b[2]);
    let n = x.hypot(z);
    if n == 0.0 {
        return (0.5 * (q[1] + p[1]), 0.5);
    }
    let c = [x / n, 0.0, z / n];
    let total = angle_between(&a, &b);
    let f = if total > 0.0 {
        (angle_between(&a, &c) / total).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (z.atan2(x.abs()).to_degrees().clamp(-90.0, 90.0), f)
}

/// Whether `x` is an odd multiple of 180 (a line where the antimeridian lies once unwrapped).
fn on_cut_line(x: f64) -> bool {
    let t = (x - 180.0) / 360.0;
    t == t.round()
}

/// The odd multiple of 180 strictly between `a` and `b`, if any (steps are at most 180 wide,
/// so there is at most one).
fn cut_line_between(a: f64, b: f64) -> Option<f64> {
    let (lo, hi) = (a.min(b), a.max(b));
    let l = 180.0 + 360.0 * (((lo - 180.0) / 360.0).floor() + 1.0);
    (l > lo && l < hi).then_some(l)
}

/// A ring with continuous longitudes and a vertex on every cut line it crosses; the total
/// change of longitude (0, or ±360 for a ring around a pole) and whether any step crossed.
fn unwrap(ring: &[Position]) -> (Vec<Position>, f64, bool) {
    let mut out: Vec<Position> = Vec::with_capacity(ring.len() + 8);
    let mut crossed = false;
    let Some(&first) = ring.first() else {
        return (out, 0.0, false);
    };
    out.push(first);
    let mut x = first[0];
    for w in ring.windows(2) {
        let (q, p) = (w[0], w[1]);
        let mut xp = x + (p[0] - q[0]) - 360.0 * ((p[0] - q[0]) / 360.0).round();
        if p[0].abs() == 180.0 {
            // A vertex on ±180 stays exactly on its line (the sum of steps can be a rounding
            // error off it).
            xp = 180.0 + 360.0 * ((xp - 180.0) / 360.0).round();
        }
        if let Some(l) = cut_line_between(x, xp) {
            let (lat, f) = crossing(&q, &p);
            out.push([l, lat, q[2] + f * (p[2] - q[2])]);
            crossed = true;
        }
        x = xp;
        out.push([xp, p[1], p[2]]);
    }
    (out, x - first[0], crossed)
}

/// A ring around a pole (winding ±360), turned to start on a cut line so it spans exactly
/// [-180, 180] (the start at -180 for an eastward ring, +180 for a westward one), then closed
/// along that meridian and the pole.
fn close_around_pole(
    ring: Vec<Position>,
    winding: f64,
    flip: bool,
    pole_hint: Option<f64>,
    nearest_start: bool,
) -> Vec<Position> {
    let n = ring.len() - 1; // the last vertex is the first one turned once round
                            // The ring turned to start at vertex `start` (on a cut line), shifted so it spans exactly
                            // [-180, 180], with its end (the start turned once round) appended.
    let turn = |start: usize| -> Vec<Position> {
        let mut turned: Vec<Position> = Vec::with_capacity(n + 4);
        turned.extend_from_slice(&ring[start..n]);
        turned.extend(ring[..start].iter().map(|p| [p[0] + winding, p[1], p[2]]));
        let target = if winding > 0.0 { -180.0 } else { 180.0 };
        let shift = target - turned[0][0];
        for p in turned.iter_mut() {
            p[0] += shift;
        }
        let first = turned[0];
        turned.push([first[0] + winding, first[1], first[2]]);
        turned
    };
    let crossings: Vec<usize> = (0..n).filter(|&i| on_cut_line(ring[i][0])).collect();
    let mut turned = turn(crossings.first().copied().unwrap_or(0));
    // The pole on the smaller side, whichever way the ring turns, as rings that do not go
    // round a pole are read: orientation is only a SHOULD in RFC 7946, and data from
    // shapefiles turns the other way. (A cap cut along its pole, Antarctica or an Arctic
    // cap, is the smaller side of its ring.)
    // A ring that already runs through a pole is a cut form fitted as it came: closed along
    // that pole, or with both, along the one on its left (RFC 7946 orientation). A ring
    // rejoined from a cut form keeps the pole that form was closed along (`pole_hint`), even
    // on its larger side: that is the region the data says it is.
    let at = |lat: f64| turned.iter().any(|p| p[1] == lat);
    let north = match (at(90.0), at(-90.0), pole_hint) {
        (true, false, _) => true,
        (false, true, _) => false,
        (true, true, _) => winding > 0.0,
        (false, false, Some(lat)) => lat > 0.0,
        (false, false, None) => north_side_area(&turned) <= 2.0 * std::f64::consts::PI,
    };
    let pole = if north != flip { 90.0 } else { -90.0 };
    // `nearest_start`: a ring crossing ±180 more than once is closed from its crossing nearest
    // that pole, so that the meridian from there to the pole meets no other part of the ring
    // (from another crossing it may cut through the ring, and the strips lose a piece).
    // Only crossings in the direction the ring turns qualify (where a ring folds back, the
    // crossings between go the other way).
    let x_at = |k: isize| -> f64 {
        let turns = k.div_euclid(n as isize);
        ring[k.rem_euclid(n as isize) as usize][0] + winding * turns as f64
    };
    let forward = |i: usize| -> bool {
        let (i, x) = (i as isize, ring[i][0]);
        let next = (1..=n as isize).map(|d| x_at(i + d)).find(|&v| v != x);
        let prev = (1..=n as isize).map(|d| x_at(i - d)).find(|&v| v != x);
        matches!((prev, next), (Some(p), Some(q)) if (q - x) * winding > 0.0 && (x - p) * winding > 0.0)
    };
    let forward_crossings: Vec<usize> = crossings.iter().copied().filter(|&i| forward(i)).collect();
    if let Some(&nearest) = forward_crossings
        .iter()
        .max_by(|&&i, &&j| (pole * ring[i][1]).total_cmp(&(pole * ring[j][1])))
    {
        if nearest_start && forward_crossings.len() > 1 && Some(&nearest) != crossings.first() {
            turned = turn(nearest);
        }
    }
    let first = turned[0];
    let end = turned[turned.len() - 1];
    turned.push([end[0], pole, end[2]]);
    turned.push([first[0], pole, first[2]]);
    turned.push(first);
    turned
}

/// The area (steradians) of the side of a closed ring around a pole that holds the north
/// pole, with great-circle edges: the triangles from the pole to each edge tile it.
fn north_side_area(ring: &[Position]) -> f64 {
    let c = [0.0, 0.0, 1.0];
    let dot = |u: &[f64; 3], v: &[f64; 3]| u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
    let units: Vec<[f64; 3]> = ring.iter().map(|p| lonlat_to_unit(p[0], p[1])).collect();
    let sum: f64 = units
        .windows(2)
        .map(|w| {
            let (a, b) = (&w[0], &w[1]);
            let bxc = [
                b[1] * c[2] - b[2] * c[1],
                b[2] * c[0] - b[0] * c[2],
                b[0] * c[1] - b[1] * c[0],
            ];
            2.0 * dot(a, &bxc).atan2(1.0 + dot(a, b) + dot(b, &c) + dot(&c, a))
        })
        .sum();
    sum.abs()
}

/// Twice the signed planar area (positive counter-clockwise) of a closed ring.
fn signed_area2(ring: &[Position]) -> f64 {
    ring.windows(2)
        .map(|w| w[0][0] * w[1][1] - w[1][0] * w[0][1])
        .sum()
}

/// Whether the point is inside the closed planar ring (even-odd rule).
fn contains(ring: &[Position], x: f64, y: f64) -> bool {
    let mut inside = false;
    for w in ring.windows(2) {
        let (a, b) = (w[0], w[1]);
        if (a[1] > y) != (b[1] > y) {
            let t = (y - a[1]) / (b[1] - a[1]);
            if x < a[0] + t * (b[0] - a[0]) {
                inside = !inside;
            }
        }
    }
    inside
}

/// Converts a polygon (closed rings of `[lon, lat, alt]`, exterior first, each step taken the
/// short way round) to lon/lat polygons within [-180, 180]: the polygon as it came when it
/// neither crosses ±180 nor winds around a pole, otherwise its pieces as described in the
/// module docs. `round` is applied to the longitudes moved by a whole turn (the output
/// precision), so they keep the digits of the rest.
///
/// A ring around a pole is closed along the pole on its left; when that leaves a piece with no
/// exterior in its strip (the ring folds back across a cut line, so in the lon/lat plane the
/// closed ring crosses itself and a piece would be lost), it is closed along the other pole
/// instead, as the `antimeridian` package reads such rings, if that loses fewer.
pub fn split_polygon(
    rings: &[Vec<Position>],
    round: &dyn Fn(f64) -> f64,
) -> Vec<Vec<Vec<Position>>> {
    split_polygon_around(rings, round, None)
}

/// [`split_polygon`] for a polygon whose exterior, if it goes round a pole, is closed along
/// the pole at latitude `pole` (90 or -90) when given: the pole a cut-form input was closed
/// along ([`super::rejoin::RejoinedPolygon::pole`]), which may be its larger side (a swath
/// or a cap forced onto the pole it does not need).
pub fn split_polygon_around(
    rings: &[Vec<Position>],
    round: &dyn Fn(f64) -> f64,
    pole: Option<f64>,
) -> Vec<Vec<Vec<Position>>> {
    split_counting_losses(rings, round, pole).0
}

/// [`split_polygon_around`], and how many pieces it lost for want of an exterior.
fn split_counting_losses(
    rings: &[Vec<Position>],
    round: &dyn Fn(f64) -> f64,
    pole: Option<f64>,
) -> (Vec<Vec<Vec<Position>>>, usize) {
    let (out, lost, polar) = split_closing(rings, round, false, pole, false);
    if lost == 0 || !polar {
        return (out, lost);
    }
    // The same pole closed from the ring's crossing nearest it, then the other pole.
    let mut best = (out, lost);
    for (flip, nearest) in [(false, true), (true, false), (true, true)] {
        let (other, lost_other, _) = split_closing(rings, round, flip, pole, nearest);
        if lost_other < best.1 {
            best = (other, lost_other);
            if best.1 == 0 {
                break;
            }
        }
    }
    best
}

/// [`split_polygon`] with rings around a pole closed along the pole on their left (`flip`:
/// on their right); also the number of pieces lost for want of an exterior, and whether any
/// ring went round a pole.
fn split_closing(
    rings: &[Vec<Position>],
    round: &dyn Fn(f64) -> f64,
    flip: bool,
    pole: Option<f64>,
    nearest_start: bool,
) -> (Vec<Vec<Vec<Position>>>, usize, bool) {
    let rings: Vec<&Vec<Position>> = rings.iter().filter(|r| r.len() >= 2).collect();
    if rings.is_empty() {
        return (Vec::new(), 0, false);
    }
    let mut any = false;
    let mut polar = false;
    let mut unwrapped: Vec<Vec<Position>> = Vec::with_capacity(rings.len());
    for ring in &rings {
        let (mut u, winding, crossed) = unwrap(ring);
        if winding.abs() > 180.0 {
            u = close_around_pole(u, winding, flip, pole, nearest_start);
            any = true;
            polar = true;
        }
        // A vertex exactly on ±180 is written with the sign of the side its edges are on
        // (and a ring passing through one is cut there), so it needs the strips too.
        any |= crossed || u.iter().any(|p| on_cut_line(p[0]));
        u.dedup();
        unwrapped.push(u);
    }
    if !any {
        return (vec![rings.into_iter().cloned().collect()], 0, false);
    }
    // Holes next to the exterior (one may have been unwrapped a turn away).
    let (lo, hi) = x_range(&unwrapped[..1]);
    let centre = 0.5 * (lo + hi);
    for ring in unwrapped.iter_mut().skip(1) {
        let mean = ring.iter().map(|p| p[0]).sum::<f64>() / ring.len() as f64;
        let shift = 360.0 * ((centre - mean) / 360.0).round();
        ring.iter_mut().for_each(|p| p[0] += shift);
    }
    // The exterior starts within [-180, 180].
    let shift = 360.0 * (-unwrapped[0][0][0] / 360.0).round();
    if shift != 0.0 {
        unwrapped.iter_mut().flatten().for_each(|p| p[0] += shift);
    }
    // Interior on the left of every edge.
    for (i, ring) in unwrapped.iter_mut().enumerate() {
        if (signed_area2(ring) > 0.0) != (i == 0) {
            ring.reverse();
        }
    }
    let (lo, hi) = x_range(&unwrapped);
    let k_lo = ((lo + 180.0) / 360.0).floor() as i64;
    let k_hi = ((hi - 180.0) / 360.0).ceil() as i64;
    let mut out = Vec::new();
    let mut lost = 0;
    for k in k_lo..=k_hi {
        let (a, b) = (360.0 * k as f64 - 180.0, 360.0 * k as f64 + 180.0);
        let (polys, lost_here) = strip(&unwrapped, a, b);
        lost += lost_here;
        for poly in polys {
            out.push(
                poly.into_iter()
                    .map(|ring| {
                        ring.into_iter()
                            .map(|p| {
                                let lon = if p[0] == a {
                                    -180.0
                                } else if p[0] == b {
                                    180.0
                                } else if k == 0 {
                                    p[0]
                                } else {
                                    round(p[0] - 360.0 * k as f64)
                                };
                                [lon.clamp(-180.0, 180.0), p[1], p[2]]
                            })
                            .collect()
                    })
                    .collect(),
            );
        }
    }
    (out, lost, polar)
}

/// Whether a polygon closed along `pole` (if it goes round one) is written back whole: no
/// piece lost in a strip, and no edge wider than 180 degrees of longitude except along a pole.
/// [`super::rejoin::rejoin_cut_polygons`] asks this of the input it rejoined: a cut form that
/// does not pass (a swath whose parts overlap across ±180, or that folds back over a pole it
/// was forced onto) is fitted as it came instead.
pub(crate) fn writes_back_whole(rings: &[Vec<Position>], pole: Option<f64>) -> bool {
    let (out, lost) = split_counting_losses(rings, &|x| x, pole);
    lost == 0
        && out.iter().flatten().all(|ring| {
            ring.windows(2).all(|w| {
                (w[1][0] - w[0][0]).abs() <= 180.0 || (w[0][1].abs() == 90.0 && w[0][1] == w[1][1])
            })
        })
}

fn x_range(rings: &[Vec<Position>]) -> (f64, f64) {
    rings
        .iter()
        .flatten()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(p[0]), hi.max(p[0]))
        })
}

/// Whether the edge `p -> q` belongs to the strip [a, b]: it runs inside it, or along one of
/// its lines with the interior (on the left) inside the strip.
fn edge_in_strip(p: &Position, q: &Position, a: f64, b: f64) -> bool {
    let m = 0.5 * (p[0] + q[0]);
    if m > a && m < b {
        return true;
    }
    if p[0] == q[0] && (p[0] == a || p[0] == b) && p[1] != q[1] {
        // Going north the interior is to the west.
        let west = q[1] > p[1];
        return if p[0] == b { west } else { !west };
    }
    false
}

/// The polygons (exterior, then holes; closed) of the strip [a, b], and the number of holes
/// left out because the strip has no exterior.
fn strip(rings: &[Vec<Position>], a: f64, b: f64) -> (Vec<Vec<Vec<Position>>>, usize) {
    let mut chains: Vec<Vec<Position>> = Vec::new();
    let mut exteriors: Vec<Vec<Position>> = Vec::new();
    let mut holes: Vec<Vec<Position>> = Vec::new();
    for (r, ring) in rings.iter().enumerate() {
        let n = ring.len() - 1;
        if n < 2 {
            continue;
        }
        let inside: Vec<bool> = (0..n)
            .map(|i| edge_in_strip(&ring[i], &ring[i + 1], a, b))
            .collect();
        if inside.iter().all(|&x| x) {
            if r == 0 {
                exteriors.push(ring.clone());
            } else {
                holes.push(ring.clone());
            }
            continue;
        }
        // Runs of edges in the strip, each from a vertex on a cut line to another.
        let Some(s) = (0..n).find(|&i| inside[i] && !inside[(i + n - 1) % n]) else {
            continue;
        };
        let mut current: Vec<Position> = Vec::new();
        for j in 0..n {
            let i = (s + j) % n;
            if inside[i] {
                if current.is_empty() {
                    current.push(ring[i]);
                }
                current.push(ring[i + 1]);
            } else if !current.is_empty() {
                chains.push(std::mem::take(&mut current));
            }
        }
        if !current.is_empty() {
            chains.push(current);
        }
    }
    // Join the chains along the cut lines: from an end on the east line north to the nearest
    // start on it, from an end on the west line south.
    let mut used = vec![false; chains.len()];
    for c0 in 0..chains.len() {
        if used[c0] {
            continue;
        }
        used[c0] = true;
        let mut ring = chains[c0].clone();
        let mut cur = c0;
        for _ in 0..=chains.len() {
            let end = *chains[cur].last().expect("a chain has two vertices");
            let north = end[0] == b;
            let next = (0..chains.len())
                .filter(|&c| (c == c0 || !used[c]) && chains[c][0][0] == end[0])
                .filter(|&c| {
                    let y = chains[c][0][1];
                    if north {
                        y >= end[1]
                    } else {
                        y <= end[1]
                    }
                })
                .min_by(|&c, &d| {
                    let (y, z) = (chains[c][0][1], chains[d][0][1]);
                    let (dy, dz) = ((y - end[1]).abs(), (z - end[1]).abs());
                    // On a tie the ring closes first.
                    dy.total_cmp(&dz).then((c != c0).cmp(&(d != c0)))
                });
            match next {
                Some(c) if c != c0 => {
                    used[c] = true;
                    let start = usize::from(ring.last() == Some(&chains[c][0]));
                    ring.extend_from_slice(&chains[c][start..]);
                    cur = c;
                }
                _ => break,
            }
        }
        if ring.first() != ring.last() {
            ring.push(ring[0]);
        }
        ring.dedup();
        if ring.len() < 4 {
            continue;
        }
        if signed_area2(&ring) >= 0.0 {
            exteriors.push(ring);
        } else {
            holes.push(ring);
        }
    }
    let mut polygons: Vec<Vec<Vec<Position>>> = exteriors.into_iter().map(|e| vec![e]).collect();
    let mut lost = 0;
    for hole in holes {
        // A vertex off the cut lines decides which exterior holds the hole.
        let p = hole
            .iter()
            .find(|p| p[0] > a && p[0] < b)
            .unwrap_or(&hole[0]);
        let owner = (0..polygons.len())
            .filter(|&i| contains(&polygons[i][0], p[0], p[1]))
            .min_by(|&i, &j| {
                signed_area2(&polygons[i][0]).total_cmp(&signed_area2(&polygons[j][0]))
            })
            .or((!polygons.is_empty()).then_some(0));
        // A hole with no exterior in its strip bounds nothing there.
        match owner {
            Some(i) => polygons[i].push(hole),
            None => lost += 1,
        }
    }
    (polygons, lost)
}

#[cfg(test)]
mod tests {
    use super::*;
    use geo::{Coord, LineString, Polygon, Validation};

    fn ring(lonlats: &[(f64, f64)]) -> Vec<Position> {
        lonlats.iter().map(|&(a, b)| [a, b, 7.0]).collect()
    }

    fn none(x: f64) -> f64 {
        x
    }

    fn valid(poly: &[Vec<Position>]) -> bool {
        let ls = |r: &Vec<Position>| {
            LineString::new(r.iter().map(|p| Coord { x: p[0], y: p[1] }).collect())
        };
        Polygon::new(ls(&poly[0]), poly[1..].iter().map(ls).collect()).is_valid()
    }

    /// Latitude where the great circle through two lon/lat points meets the meridian 180,
    /// from the circle's normal (independent of the code under test).
    fn great_circle_lat_at_180(p: (f64, f64), q: (f64, f64)) -> f64 {
        let u = |(lon, lat): (f64, f64)| {
            let (lon, lat) = (lon.to_radians(), lat.to_radians());
            [lat.cos() * lon.cos(), lat.cos() * lon.sin(), lat.sin()]
        };
        let (a, b) = (u(p), u(q));
        let n = [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ];
        // On the meridian 180: (-cos φ, 0, sin φ) · n = 0  =>  tan φ = n_x / n_z.
        (n[0] / n[2]).atan().to_degrees()
    }

    #[test]
    fn a_polygon_inside_the_range_comes_back_as_it_came() {
        let r = ring(&[(0.0, 0.0), (0.0, 10.0), (10.0, 10.0), (0.0, 0.0)]);
        assert_eq!(
            split_polygon(std::slice::from_ref(&r), &none),
            vec![vec![r]]
        );
    }

    #[test]
    fn a_crossing_is_cut_on_the_great_circle() {
        let r = ring(&[
            (170.0, 40.0),
            (-170.0, 40.0),
            (-170.0, 50.0),
            (170.0, 50.0),
            (170.0, 40.0),
        ]);
        let polys = split_polygon(&[r], &none);
        assert_eq!(polys.len(), 2, "{polys:?}");
        let south = great_circle_lat_at_180((170.0, 40.0), (-170.0, 40.0));
        let north = great_circle_lat_at_180((-170.0, 50.0), (170.0, 50.0));
        assert!(south > 40.4 && south < 40.5, "{south}");
        for poly in &polys {
            assert!(valid(poly), "{poly:?}");
            assert!(signed_area2(&poly[0]) > 0.0);
            let n = poly[0].len() - 1;
            let seam: Vec<f64> = poly[0][..n]
                .iter()
                .filter(|p| p[0].abs() == 180.0)
                .map(|p| p[1])
                .collect();
            assert_eq!(seam.len(), 2, "{poly:?}");
            assert!(
                seam.iter().any(|y| (y - south).abs() < 1e-9),
                "{seam:?} {south}"
            );
            assert!(
                seam.iter().any(|y| (y - north).abs() < 1e-9),
                "{seam:?} {north}"
            );
            assert!(poly[0].iter().all(|p| p[2] == 7.0));
        }
    }

    #[test]
    fn a_cap_around_a_pole_keeps_every_vertex_and_closes_along_the_pole() {
        // 72 S every 10 degrees, westward (as the coast of Antarctica runs in some files).
        let mut lonlats: Vec<(f64, f64)> =
            (0..36).map(|i| (175.0 - 10.0 * i as f64, -72.0)).collect();
        lonlats
            .iter_mut()
            .for_each(|p| p.0 = (p.0 + 540.0).rem_euclid(360.0) - 180.0);
        lonlats.push(lonlats[0]);
        let polys = split_polygon(&[ring(&lonlats)], &none);
        assert_eq!(polys.len(), 1, "{polys:?}");
        let out = &polys[0][0];
        assert!(valid(&polys[0]));
        for &(lon, lat) in &lonlats {
            assert!(
                out.iter().any(|p| p[0] == lon && p[1] == lat),
                "({lon}, {lat}) lost"
            );
        }
        assert!(out.iter().any(|p| p == &[-180.0, -90.0, 7.0]));
        assert!(out.iter().any(|p| p == &[180.0, -90.0, 7.0]));
        assert!(signed_area2(out) > 0.0);
    }

    #[test]
    fn a_ring_crossing_many_times_gives_simple_pieces() {
        // A comb: teeth reaching across 180 from the east side and back.
        let mut lonlats = vec![(175.0, 0.0)];
        for t in 0..5 {
            let y = 2.0 * t as f64;
            lonlats.extend([
                (-175.0, y),
                (-175.0, y + 1.0),
                (178.0, y + 1.0),
                (178.0, y + 2.0),
            ]);
        }
        lonlats.extend([(175.0, 10.0), (175.0, 0.0)]);
        let polys = split_polygon(&[ring(&lonlats)], &none);
        let (east, west): (Vec<_>, Vec<_>) = polys.iter().partition(|p| p[0][0][0] > 0.0);
        assert_eq!(east.len(), 1, "{polys:?}");
        assert_eq!(west.len(), 5, "{polys:?}");
        for poly in &polys {
            assert!(valid(poly), "{poly:?}");
        }
        for &(lon, lat) in &lonlats {
            assert!(polys
                .iter()
                .flatten()
                .flatten()
                .any(|p| p[0] == lon && p[1] == lat));
        }
    }

    #[test]
    fn a_hole_across_the_line_is_cut_with_its_exterior() {
        let ext = ring(&[
            (170.0, -10.0),
            (-170.0, -10.0),
            (-170.0, 10.0),
            (170.0, 10.0),
            (170.0, -10.0),
        ]);
        let hole = ring(&[
            (175.0, -5.0),
            (175.0, 5.0),
            (-175.0, 5.0),
            (-175.0, -5.0),
            (175.0, -5.0),
        ]);
        let inner = ring(&[(172.0, -1.0), (172.0, 1.0), (173.0, 1.0), (172.0, -1.0)]);
        let polys = split_polygon(&[ext, hole, inner], &none);
        assert_eq!(polys.len(), 2, "{polys:?}");
        for poly in &polys {
            assert!(valid(poly), "{poly:?}");
        }
        // The islet-free hole in the east piece: the east polygon keeps the small hole.
        let east = polys.iter().find(|p| p[0][0][0] > 0.0).unwrap();
        assert_eq!(east.len(), 2, "{east:?}");
    }

    #[test]
    fn a_vertex_on_the_antimeridian_takes_the_sign_of_its_side() {
        // The antimeridian package's point-on-antimeridian: a vertex at +180 between vertices
        // in the west; and a ring passing through a vertex at 180 from east to west.
        let west = ring(&[
            (-176.9, -12.8),
            (180.0, -15.7),
            (-176.8, -18.6),
            (-170.0, -15.0),
            (-176.9, -12.8),
        ]);
        let out = split_polygon(std::slice::from_ref(&west), &none);
        assert_eq!(out.len(), 1);
        assert!(out[0][0].iter().any(|p| p[0] == -180.0));
        assert!(out[0][0].iter().all(|p| p[0] != 180.0));
        assert!(valid(&out[0]));
        let through = ring(&[
            (179.0, 0.0),
            (180.0, 1.0),
            (-179.0, 0.0),
            (180.0, -1.0),
            (179.0, 0.0),
        ]);
        let mut out = split_polygon(std::slice::from_ref(&through), &none);
        out.sort_by(|a, b| a[0][0][0].total_cmp(&b[0][0][0]));
        assert_eq!(out.len(), 2, "{out:?}");
        for poly in &out {
            assert!(valid(poly));
            let (lo, hi) = x_range(&poly[..1]);
            assert!(hi - lo <= 1.0 + 1e-12, "{poly:?}");
        }
    }

    #[test]
    fn moved_longitudes_are_rounded() {
        let r = ring(&[
            (179.0, 0.0),
            (-179.123456789, 0.0),
            (-179.0, 1.0),
            (179.0, 1.0),
            (179.0, 0.0),
        ]);
        let round = |x: f64| (x * 1e3).round() / 1e3;
        let polys = split_polygon(&[r], &round);
        let west = polys
            .iter()
            .find(|p| p[0].iter().any(|q| q[0] < 0.0 && q[0] > -180.0))
            .unwrap();
        assert!(west[0].iter().any(|q| q[0] == -179.123), "{west:?}");
    }
}
