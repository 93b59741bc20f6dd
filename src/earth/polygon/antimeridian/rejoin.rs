//! Polygons that arrive cut at ±180, rejoined into rings on the sphere before fitting.
//!
//! Natural Earth, GDAL's RFC 7946 writer and geopandas write a polygon that crosses the
//! antimeridian as parts on either side (Fiji, Chukotka), and a polygon around a pole as one
//! ring with edges along the ±180 meridian and a closure along the pole (Antarctica). Fitted
//! as they are, those edges are part of the outline: the curve runs up to the pole and back,
//! and the parts are fitted (and judged) separately. On the sphere they are one ring.
//!
//! [`rejoin_cut_polygons`] removes the *cut edges* (an edge along one of the ±180 meridians,
//! or one with an end at a pole and the other on the meridian or the pole), breaks the rings
//! there into chains, and joins each chain's end to the chain that starts at the same point
//! of the sphere (the same latitude at +180 or -180; any longitude at a pole). When every chain
//! joins into a closed ring, those rings replace the input (exteriors and holes separately,
//! each hole kept with the exterior its polygon became part of); otherwise the geometry is
//! left as it came, so a polygon that merely touches ±180 is not changed. The rejoined rings
//! are lists of the input's own positions (cloned, altitudes included): nothing is moved, and
//! the output is cut again where the fitted curve crosses ±180 ([`super::split_polygon`]).

use serde_json::Value;

/// Two latitudes closer than this (degrees, about 1 cm) are the same point on the seam.
const SAME_LAT_DEG: f64 = 1e-7;

/// A position by (polygon, ring, index) in the input.
type At = (usize, usize, usize);

/// One rejoined polygon.
#[derive(Clone, Debug, PartialEq)]
pub struct RejoinedPolygon {
    /// Its rings, exterior first: (pointer of the input ring each starts from, ring value).
    pub rings: Vec<(String, Value)>,
    /// For an exterior that goes round a pole, the latitude of the pole (90 or -90) the input
    /// was closed along: the output is closed along the same one
    /// ([`super::split::split_polygon_around`]), which is not always the smaller side.
    pub pole: Option<f64>,
}

/// Rejoined polygons.
pub type Rejoined = Vec<RejoinedPolygon>;

fn is_pole(lat: f64) -> bool {
    lat.abs() == 90.0
}

fn on_seam(lon: f64) -> bool {
    lon.abs() == 180.0
}

/// Whether the edge `a -> b` is an edge of the cut, not of the outline.
fn cut_edge(a: [f64; 2], b: [f64; 2]) -> bool {
    let seam_or_pole = |p: [f64; 2]| on_seam(p[0]) || is_pole(p[1]);
    if !(seam_or_pole(a) && seam_or_pole(b)) {
        return false;
    }
    (on_seam(a[0]) && a[0] == b[0]) || is_pole(a[1]) || is_pole(b[1])
}

/// Whether `a` and `b` are the same point of the sphere on the seam or at a pole.
fn same_point(a: [f64; 2], b: [f64; 2]) -> bool {
    if (a[1] - b[1]).abs() > SAME_LAT_DEG {
        return false;
    }
    is_pole(a[1]) || a[0] == b[0] || (on_seam(a[0]) && on_seam(b[0]))
}

/// The lon/lat of a position value, if it is one.
fn lonlat(p: &Value) -> Option<[f64; 2]> {
    let a = p.as_array()?;
    let (lon, lat) = (a.first()?.as_f64()?, a.get(1)?.as_f64()?);
    ((-180.0..=180.0).contains(&lon) && (-90.0..=90.0).contains(&lat)).then_some([lon, lat])
}

/// Rings of one role (exteriors or holes) rejoined: each output ring is a closed list of
/// positions, with the polygon its first chain came from. `None` when a chain has no partner;
/// `Some(Err(at))` when a chain closes on itself with fewer than 3 distinct points: the ring it
/// came from (`at`) bounds no area on the sphere.
type Joined = Result<Vec<(usize, Vec<At>)>, At>;
fn join_rings(rings: &[(usize, usize, &[[f64; 2]])]) -> Option<Joined> {
    let mut closed: Vec<(usize, Vec<At>)> = Vec::new();
    let mut chains: Vec<(usize, Vec<At>)> = Vec::new();
    for &(p, r, pts) in rings {
        // Without the closing position.
        let n = if pts.len() > 1 && pts[0] == pts[pts.len() - 1] {
            pts.len() - 1
        } else {
            pts.len()
        };
        let cut: Vec<bool> = (0..n).map(|i| cut_edge(pts[i], pts[(i + 1) % n])).collect();
        if !cut.iter().any(|&c| c) {
            let mut ring: Vec<At> = (0..n).map(|i| (p, r, i)).collect();
            ring.push((p, r, 0));
            closed.push((p, ring));
            continue;
        }
        if cut.iter().all(|&c| c) {
            return Some(Err((p, r, 0)));
        }
        // Chains of outline edges between cut edges; a lone vertex between two cut edges
        // (a pole corner) is part of the cut.
        let s = (0..n).find(|&i| cut[(i + n - 1) % n])?;
        let mut current: Vec<At> = vec![(p, r, s)];
        for j in 0..n {
            let i = (s + j) % n;
            if cut[i] {
                if current.len() >= 2 {
                    chains.push((p, std::mem::take(&mut current)));
                }
                current = vec![(p, r, (i + 1) % n)];
            } else {
                current.push((p, r, (i + 1) % n));
            }
        }
        if current.len() >= 2 {
            chains.push((p, current));
        }
    }
    let point = |at: &At| -> [f64; 2] {
        let &(p, r, i) = at;
        rings
            .iter()
            .find(|(q, s, _)| *q == p && *s == r)
            .map(|(_, _, pts)| pts[i])
            .expect("a position of these rings")
    };
    let mut used = vec![false; chains.len()];
    for c0 in 0..chains.len() {
        if used[c0] {
            continue;
        }
        used[c0] = true;
        let mut ring = chains[c0].1.clone();
        let mut cur = c0;
        loop {
            let end = point(chains[cur].1.last().expect("a chain has two positions"));
            if same_point(end, point(&chains[c0].1[0])) {
                // The last position is the first one's twin across the seam: close on the first.
                ring.pop();
                ring.push(chains[c0].1[0]);
                break;
            }
            let next =
                (0..chains.len()).find(|&c| !used[c] && same_point(end, point(&chains[c].1[0])))?;
            used[next] = true;
            ring.pop();
            ring.extend_from_slice(&chains[next].1);
            cur = next;
        }
        if ring.len() < 4 {
            return Some(Err(chains[c0].1[0]));
        }
        closed.push((chains[c0].0, ring));
    }
    Some(Ok(closed))
}

/// Rejoins a polygon set cut at ±180 (see the module docs). `polygons` are the (pointer,
/// value) of each polygon's rings array; the result is the new polygons, each a list of
/// (pointer of the input ring it starts from, ring value). `None` when nothing is cut, a
/// chain has no partner, or a position is not a lon/lat pair (the usual checks then report
/// it where it is). `Some(Err(pointer))` names a ring whose every edge is cut, so on the
/// sphere it has fewer than 3 distinct points and bounds no area: a latitude band or the
/// whole world drawn from -180 to 180 in the lon/lat plane (-180 and 180 are one meridian).
pub fn rejoin_cut_polygons(polygons: &[(String, &Value)]) -> Option<Result<Rejoined, String>> {
    let mut parsed: Vec<Vec<Vec<[f64; 2]>>> = Vec::with_capacity(polygons.len());
    let mut any_cut = false;
    for (_, poly) in polygons {
        let mut rings = Vec::new();
        for ring in poly.as_array()? {
            let pts: Vec<[f64; 2]> = ring.as_array()?.iter().map(lonlat).collect::<Option<_>>()?;
            // An open or short ring is reported by the usual ring checks, where it is.
            if pts.len() < 4 || pts[0] != pts[pts.len() - 1] {
                return None;
            }
            any_cut |= pts.windows(2).any(|w| cut_edge(w[0], w[1]));
            rings.push(pts);
        }
        if rings.is_empty() {
            return None;
        }
        parsed.push(rings);
    }
    if !any_cut {
        return None;
    }
    let exteriors: Vec<(usize, usize, &[[f64; 2]])> = parsed
        .iter()
        .enumerate()
        .map(|(p, rings)| (p, 0, rings[0].as_slice()))
        .collect();
    let holes: Vec<(usize, usize, &[[f64; 2]])> = parsed
        .iter()
        .enumerate()
        .flat_map(|(p, rings)| {
            rings
                .iter()
                .enumerate()
                .skip(1)
                .map(move |(r, pts)| (p, r, pts.as_slice()))
        })
        .collect();
    let pointer_of = |at: &At| format!("{}/{}", polygons[at.0].0, at.1);
    let (joined_ext, joined_holes) = match (join_rings(&exteriors)?, join_rings(&holes)?) {
        (Ok(e), Ok(h)) => (e, h),
        (Err(at), _) | (_, Err(at)) => return Some(Err(pointer_of(&at))),
    };
    // Which new polygon each input polygon's exterior went into.
    let mut home = vec![usize::MAX; polygons.len()];
    for (k, (_, ring)) in joined_ext.iter().enumerate() {
        for &(p, _, _) in ring {
            if home[p] == usize::MAX {
                home[p] = k;
            }
        }
    }
    let value_of = |ring: &[At]| -> Value {
        Value::Array(
            ring.iter()
                .map(|&(p, r, i)| polygons[p].1[r][i].clone())
                .collect(),
        )
    };
    // How far a rejoined ring turns round the poles (degrees of longitude).
    let winding = |ring: &[At]| -> f64 {
        ring.windows(2)
            .map(|w| {
                let (a, b) = (
                    parsed[w[0].0][w[0].1][w[0].2],
                    parsed[w[1].0][w[1].1][w[1].2],
                );
                let d = b[0] - a[0];
                d - 360.0 * (d / 360.0).round()
            })
            .sum()
    };
    // Which input polygons each rejoined exterior draws on.
    let sources = |k: usize, ring: &[At]| -> Vec<usize> {
        let mut ps: Vec<usize> = ring.iter().map(|a| a.0).collect();
        ps.push(k);
        ps.sort_unstable();
        ps.dedup();
        ps
    };
    let mut out: Rejoined = Vec::with_capacity(joined_ext.len());
    for (_, ring) in &joined_ext {
        let ps = sources(0, ring);
        let at_pole = |lat: f64| ps.iter().any(|&p| parsed[p][0].iter().any(|q| q[1] == lat));
        let (north, south) = (at_pole(90.0), at_pole(-90.0));
        let w = winding(ring);
        let winds = w.abs() > 180.0;
        // A region holding a pole its ring does not go round (both poles, or the rest of the
        // world around a small ring) or one whose exterior on the sphere is several rings (an
        // ocean) is not one ring per polygon: it is fitted as it came, cut edges and all.
        let shared = ps.iter().any(|&p| {
            joined_ext
                .iter()
                .filter(|(_, r)| r.iter().any(|a| a.0 == p))
                .count()
                > 1
        });
        if ((north || south) && !(winds && north != south)) || (shared && winds) {
            return None;
        }
        out.push(RejoinedPolygon {
            rings: vec![(pointer_of(&ring[0]), value_of(ring))],
            pole: (winds && north != south).then_some(if north { 90.0 } else { -90.0 }),
        });
    }
    for (p, ring) in &joined_holes {
        let k = home[*p];
        if k == usize::MAX {
            return None;
        }
        out[k].rings.push((pointer_of(&ring[0]), value_of(ring)));
    }
    // The rejoined polygon must be one the output can be written as again; one that is not
    // (parts overlapping across ±180, a swath folded back over the pole it was closed along)
    // is fitted as it came.
    for poly in &out {
        let rings: Vec<Vec<[f64; 3]>> = poly
            .rings
            .iter()
            .map(|(_, r)| {
                r.as_array()
                    .into_iter()
                    .flatten()
                    .filter_map(lonlat)
                    .map(|q| [q[0], q[1], 0.0])
                    .collect()
            })
            .collect();
        if !super::split::writes_back_whole(&rings, poly.pole) {
            return None;
        }
    }
    Some(Ok(out))
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    /// The polygons of a MultiPolygon's coordinates with their pointers.
    fn polygons(coords: &Value) -> Vec<(String, &Value)> {
        coords
            .as_array()
            .unwrap()
            .iter()
            .enumerate()
            .map(|(i, p)| (format!("/coordinates/{i}"), p))
            .collect()
    }

    fn run(coords: Value) -> Option<Vec<Vec<Value>>> {
        rejoin_cut_polygons(&polygons(&coords)).map(|v| {
            v.expect("a ring with area")
                .into_iter()
                .map(|p| p.rings.into_iter().map(|(_, r)| r).collect())
                .collect()
        })
    }

    fn no_area(coords: Value) -> Option<String> {
        rejoin_cut_polygons(&polygons(&coords)).and_then(Result::err)
    }

    #[test]
    fn a_band_or_the_whole_world_drawn_from_minus_180_to_180_bounds_no_area() {
        // The antimeridian package's latitude band and GDAL's whole-world rectangle: on the
        // sphere each has 2 distinct points.
        let band = json!([[[[-180, 40], [180, 40], [180, 50], [-180, 50], [-180, 40]]]]);
        assert_eq!(no_area(band).as_deref(), Some("/coordinates/0/0"));
        let world = json!([
            [[[0, 0], [1, 0], [1, 1], [0, 0]]],
            [[[-180, -90], [180, -90], [180, 90], [-180, 90], [-180, -90]]]
        ]);
        assert_eq!(no_area(world).as_deref(), Some("/coordinates/1/0"));
    }

    #[test]
    fn an_open_or_short_ring_is_left_to_the_ring_checks() {
        // GDAL's t57: the second cap part has 3 positions and does not close.
        let coords = json!([
            [[[180.0, 89.08], [180.0, 90.0], [135.0, 88.7], [180.0, 89.08]]],
            [[[-180.0, 90.0], [-180.0, 89.08], [-135.0, 88.7]]]
        ]);
        assert!(
            rejoin_cut_polygons(&[("/0".into(), &coords[0]), ("/1".into(), &coords[1])]).is_none()
        );
    }

    #[test]
    fn a_polar_cap_cut_at_the_seam_becomes_one_ring_around_the_pole() {
        // Antarctica as Natural Earth writes it: coast eastward, down 180, along the pole, up -180.
        let coords = json!([[[
            [-180.0, -84.0],
            [-90.0, -80.0],
            [0.0, -70.0],
            [90.0, -68.0],
            [180.0, -84.0],
            [180.0, -90.0],
            [-180.0, -90.0],
            [-180.0, -84.0]
        ]]]);
        let out = run(coords).unwrap();
        assert_eq!(out.len(), 1);
        assert_eq!(out[0].len(), 1);
        let ring = out[0][0].as_array().unwrap();
        // The coast only, closed: no vertex at the pole, one at the seam.
        assert_eq!(ring.len(), 5, "{ring:?}");
        assert!(ring.iter().all(|p| p[1].as_f64().unwrap() > -89.0));
        assert_eq!(ring.first(), ring.last());
    }

    #[test]
    fn parts_on_either_side_of_the_seam_become_one_ring() {
        // Fiji-like: a west part ending at +180 and an east part starting at -180.
        let coords = json!([
            [[
                [178.0, -17.0],
                [180.0, -17.0],
                [180.0, -16.0],
                [178.0, -16.0],
                [178.0, -17.0]
            ]],
            [[
                [-180.0, -16.0],
                [-180.0, -17.0],
                [-179.0, -17.0],
                [-179.0, -16.0],
                [-180.0, -16.0]
            ]],
            [[[10.0, 10.0], [11.0, 10.0], [11.0, 11.0], [10.0, 10.0]]]
        ]);
        let out = run(coords).unwrap();
        assert_eq!(out.len(), 2, "{out:?}");
        let joined = out
            .iter()
            .find(|p| p[0].as_array().unwrap().len() > 4)
            .unwrap();
        let ring = joined[0].as_array().unwrap();
        // 3 + 3 outline positions and the two seam crossings once each, closed.
        let lons: Vec<f64> = ring.iter().map(|p| p[0].as_f64().unwrap()).collect();
        assert_eq!(ring.first(), ring.last());
        assert!(lons.contains(&-179.0) && lons.contains(&178.0), "{lons:?}");
        assert_eq!(ring.len(), 7, "{ring:?}");
    }

    #[test]
    fn a_polygon_touching_the_seam_without_a_partner_is_left_alone() {
        let coords = json!([[[
            [170.0, 0.0],
            [180.0, 0.0],
            [180.0, 10.0],
            [170.0, 10.0],
            [170.0, 0.0]
        ]]]);
        assert!(run(coords).is_none());
        let plain = json!([[[[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 0.0]]]]);
        assert!(run(plain).is_none());
    }

    #[test]
    fn altitudes_and_holes_come_along() {
        let coords = json!([
            [
                [
                    [170.0, -10.0, 5.0],
                    [180.0, -10.0, 5.0],
                    [180.0, 10.0, 5.0],
                    [170.0, 10.0, 5.0],
                    [170.0, -10.0, 5.0]
                ],
                [[172.0, -1.0], [172.0, 1.0], [173.0, 1.0], [172.0, -1.0]]
            ],
            [[
                [-180.0, 10.0, 5.0],
                [-180.0, -10.0, 5.0],
                [-170.0, -10.0, 5.0],
                [-170.0, 10.0, 5.0],
                [-180.0, 10.0, 5.0]
            ]]
        ]);
        let out = run(coords).unwrap();
        assert_eq!(out.len(), 1);
        assert_eq!(out[0].len(), 2, "the hole stays with its exterior");
        assert!(out[0][0].as_array().unwrap().iter().all(|p| p[2] == 5.0));
    }
}
