//! The arcs of a polygon coverage on the sphere: rings cut at junctions into boundary pieces,
//! each piece stored once and referenced (forwards or reversed) by every ring it bounds.
//!
//! * **Vertices.** Positions within [`SHARED_VERTEX_RAD`] (0.6 mm) of an earlier position are
//!   the same vertex, snapped to the first one seen (in input order): TopoJSON-derived input is
//!   vertex-identical, and rounding noise far below any input's precision (lon/lat 180 and
//!   -180, or any longitude at a pole, are one point on the sphere) is merged too. Positions
//!   farther apart are distinct vertices, so two borders digitised separately with gaps above
//!   0.6 mm are *unshared*: each is an arc of its own, fitted on its own, and the gap between
//!   them stays in the output as it was in the input (`shared_arcs` in the report says how much
//!   was found shared).
//! * **Junctions.** A vertex is a junction when its neighbours along all rings are not exactly
//!   two vertices: there the set of rings on either side of the boundary changes (three or more
//!   features meet, a shared border ends, a ring touches another at a point).
//! * **Arcs.** Each ring is cut at its junctions; a ring with none is one closed arc. An arc is
//!   keyed by its vertex sequence, so the same piece met again in the other direction (the
//!   neighbour's side of a border, an enclave's shell and its surrounding hole) is the same arc,
//!   used reversed.

use crate::sphere::geometry::point::angle_between;
// FxHash: the vertex snapping looks up 27 cells per input point; SipHash was a fifth of the
// graph's build on the 10m countries. No map is iterated, so the order of nothing depends on it.
use rustc_hash::FxHashMap as HashMap;

/// Positions closer than this (radians; 0.6 mm on the Earth) are one vertex: the repeat rule of
/// [`REPEAT_ANGLE_RAD`](crate::earth::curve::positions::REPEAT_ANGLE_RAD), applied across rings.
pub const SHARED_VERTEX_RAD: f64 = crate::earth::curve::positions::REPEAT_ANGLE_RAD;

/// One ring of the input: its positions as unit vectors, closing position included or not.
#[derive(Clone, Debug)]
pub struct InputRing {
    /// The positions as unit vectors.
    pub points: Vec<[f64; 3]>,
}

/// A use of an arc by a ring.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ArcUse {
    /// Index into [`ArcGraph::arcs`].
    pub arc: usize,
    /// The ring runs along the arc backwards.
    pub reversed: bool,
}

impl ArcUse {
    /// The TopoJSON arc index: `arc`, or `~arc` (= `-arc - 1`) when reversed.
    pub fn topojson_index(&self) -> i64 {
        if self.reversed {
            -(self.arc as i64) - 1
        } else {
            self.arc as i64
        }
    }
}

/// A boundary piece between two junctions, or a whole ring without junctions.
#[derive(Clone, Debug, PartialEq)]
pub struct Arc {
    /// Vertex indices in order; a closed arc ends with its first vertex again.
    pub vertices: Vec<usize>,
    /// A ring without junctions (first vertex = last).
    pub closed: bool,
    /// How many ring sides use it (1: an outer boundary; 2: a border between neighbours).
    pub uses: usize,
}

/// Vertices, arcs, and every ring as a list of arc uses.
#[derive(Clone, Debug, Default)]
pub struct ArcGraph {
    /// The distinct vertices (unit vectors; the first position seen of each).
    pub vertices: Vec<[f64; 3]>,
    /// The arcs.
    pub arcs: Vec<Arc>,
    /// For each input ring, its arcs in ring order (empty for a ring of under 3 distinct
    /// vertices, see [`ArcGraph::short_rings`]).
    pub rings: Vec<Vec<ArcUse>>,
    /// Input rings with fewer than 3 distinct vertices (by index): not areas.
    pub short_rings: Vec<usize>,
    /// How many vertices are junctions.
    pub junctions: usize,
}

/// Snaps unit vectors to vertex indices: each position becomes the vertex within
/// [`SHARED_VERTEX_RAD`] of it that comes first by (fine cell, index), where fine cells are
/// [`SHARED_VERTEX_RAD`] wide and only vertices in the 27 fine cells around the position count;
/// else a new vertex. The vertices are kept in a hash grid of coarse cells, [`COARSE_CELL`]
/// fine cells wide, so a position looks in the coarse cells its neighbourhood reaches: one for
/// most positions (27 lookups per position were three quarters of the graph's build on the 10m
/// countries).
struct Snapper {
    /// The last vertex put in a coarse cell, by the cell's key ([`Snapper::key`]).
    last: HashMap<u64, usize>,
    /// For each vertex, the vertex put before it under the same key ([`NONE`]: none).
    before: Vec<usize>,
    vertices: Vec<[f64; 3]>,
}

/// Fine cells in a coarse cell of [`Snapper`], along each axis: a position's neighbourhood
/// (2 [`SHARED_VERTEX_RAD`] each way) crosses a coarse cell's side for 1 position in 16 per
/// axis.
const COARSE_CELL: f64 = 64.0;

/// No vertex.
const NONE: usize = usize::MAX;

impl Snapper {
    fn with_capacity(n: usize) -> Snapper {
        let mut last = HashMap::default();
        last.reserve(n);
        Snapper {
            last,
            before: Vec::with_capacity(n),
            vertices: Vec::with_capacity(n),
        }
    }

    fn fine_cell(p: &[f64; 3]) -> [i64; 3] {
        p.map(|x| floor_i64(x / SHARED_VERTEX_RAD))
    }

    fn coarse_cell(x: f64) -> i64 {
        floor_i64(x / (SHARED_VERTEX_RAD * COARSE_CELL))
    }

    /// A coarse cell's key. Cells whose keys collide share a list, which only adds vertices
    /// to compare: the answer does not depend on it.
    fn key(c: [i64; 3]) -> u64 {
        (c[0] as u64)
            .wrapping_mul(0x9E37_79B9_7F4A_7C15)
            .wrapping_add((c[1] as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F))
            .wrapping_add((c[2] as u64).wrapping_mul(0x1656_67B1_9E37_79F9))
    }

    fn vertex(&mut self, p: &[f64; 3]) -> usize {
        let fine = Self::fine_cell(p);
        // Every vertex of the 27 fine cells around `p` lies within two fine cells of it.
        let reach = 2.0 * SHARED_VERTEX_RAD;
        let lo = p.map(|x| Self::coarse_cell(x - reach));
        let hi = p.map(|x| Self::coarse_cell(x + reach));
        let mut best: Option<([i64; 3], usize)> = None;
        for cx in lo[0]..=hi[0] {
            for cy in lo[1]..=hi[1] {
                for cz in lo[2]..=hi[2] {
                    let mut i = self.last.get(&Self::key([cx, cy, cz])).copied();
                    while let Some(v) = i.filter(|&v| v != NONE) {
                        i = Some(self.before[v]);
                        if angle_between(&self.vertices[v], p) > SHARED_VERTEX_RAD {
                            continue;
                        }
                        let f = Self::fine_cell(&self.vertices[v]);
                        if (0..3).all(|k| (f[k] - fine[k]).abs() <= 1)
                            && best.is_none_or(|b| (f, v) < b)
                        {
                            best = Some((f, v));
                        }
                    }
                }
            }
        }
        if let Some((_, v)) = best {
            return v;
        }
        let v = self.vertices.len();
        self.vertices.push(*p);
        let key = Self::key(p.map(Self::coarse_cell));
        self.before.push(self.last.insert(key, v).unwrap_or(NONE));
        v
    }
}

/// `y.floor() as i64`, without a call: baseline x86-64 has no rounding instruction, so
/// `floor` is a call into libm, and the snapping makes a dozen of them per position (a third
/// of the graph's build on the 10m countries). Truncation rounds towards zero, so a negative
/// `y` with a fraction is one more than its floor; the cast saturates (and sends NaN to 0) as
/// `floor` then the cast do.
fn floor_i64(y: f64) -> i64 {
    let t = y as i64;
    if (t as f64) > y {
        t.saturating_sub(1)
    } else {
        t
    }
}

impl ArcGraph {
    /// Finds the arcs of `rings` (see the module docs). Deterministic: the same input gives the
    /// same vertices, arcs and uses, in input order.
    pub fn build(rings: &[InputRing]) -> ArcGraph {
        let mut snap = Snapper::with_capacity(rings.iter().map(|r| r.points.len()).sum());
        // Each ring as a cycle of distinct vertices (no closing repeat).
        let mut cycles: Vec<Vec<usize>> = Vec::with_capacity(rings.len());
        for r in rings {
            let mut cyc: Vec<usize> = Vec::with_capacity(r.points.len());
            for p in &r.points {
                let v = snap.vertex(p);
                if cyc.last() != Some(&v) {
                    cyc.push(v);
                }
            }
            while cyc.len() > 1 && cyc.first() == cyc.last() {
                cyc.pop();
            }
            cycles.push(cyc);
        }
        let mut graph = ArcGraph {
            vertices: snap.vertices,
            ..ArcGraph::default()
        };
        // Neighbours of each vertex along all rings: the first two, and how many (3 for more).
        let mut neighbours: Vec<Neighbours> = vec![Neighbours::default(); graph.vertices.len()];
        for cyc in cycles.iter().filter(|c| !is_spike(c)) {
            let n = cyc.len();
            for i in 0..n {
                let (v, next) = (cyc[i], cyc[(i + 1) % n]);
                neighbours[v].add(next);
                neighbours[next].add(v);
            }
        }
        let junction: Vec<bool> = neighbours.iter().map(|n| n.count != 2).collect();
        graph.junctions = neighbours
            .iter()
            .filter(|n| n.count != 2 && n.count != 0)
            .count();
        let mut open: HashMap<Vec<usize>, usize> = HashMap::default();
        let mut closed: HashMap<Vec<usize>, usize> = HashMap::default();
        for (ri, cyc) in cycles.iter().enumerate() {
            if is_spike(cyc) {
                graph.short_rings.push(ri);
                graph.rings.push(Vec::new());
                continue;
            }
            let n = cyc.len();
            let uses = match cyc.iter().position(|&v| junction[v]) {
                None => {
                    // A ring without junctions: one closed arc, keyed by its cycle started at
                    // its smallest vertex and run towards the smaller neighbour.
                    let (key, reversed) = canonical_cycle(cyc);
                    let arc = *closed.entry(key).or_insert_with(|| {
                        let mut vertices = if reversed {
                            cyc.iter().rev().copied().collect::<Vec<_>>()
                        } else {
                            cyc.clone()
                        };
                        vertices.push(vertices[0]);
                        graph.arcs.push(Arc {
                            vertices,
                            closed: true,
                            uses: 0,
                        });
                        graph.arcs.len() - 1
                    });
                    vec![ArcUse { arc, reversed }]
                }
                Some(start) => {
                    let mut uses = Vec::new();
                    let mut piece = vec![cyc[start]];
                    for k in 1..=n {
                        let v = cyc[(start + k) % n];
                        piece.push(v);
                        if junction[v] {
                            uses.push(open_arc(&mut graph.arcs, &mut open, &piece));
                            piece = vec![v];
                        }
                    }
                    uses
                }
            };
            for u in &uses {
                graph.arcs[u.arc].uses += 1;
            }
            graph.rings.push(uses);
        }
        graph
    }

    /// The unit vectors of an arc's vertices, in the arc's own direction.
    pub fn arc_points(&self, arc: usize) -> Vec<[f64; 3]> {
        self.arcs[arc]
            .vertices
            .iter()
            .map(|&v| self.vertices[v])
            .collect()
    }
}

/// A cycle of fewer than 3 distinct vertices (out and back): no area.
fn is_spike(cyc: &[usize]) -> bool {
    let Some(&a) = cyc.first() else {
        return true;
    };
    match cyc.iter().find(|&&v| v != a) {
        None => true,
        Some(&b) => cyc.iter().all(|&v| v == a || v == b),
    }
}

/// The distinct neighbours of a vertex along the rings, as far as junctions need them: the
/// first two, and how many there are, 3 standing for 3 or more.
#[derive(Clone, Copy, Debug, Default)]
struct Neighbours {
    first: [usize; 2],
    count: u8,
}

impl Neighbours {
    fn add(&mut self, v: usize) {
        let n = usize::from(self.count);
        if n < 3 && !self.first[..n.min(2)].contains(&v) {
            if n < 2 {
                self.first[n] = v;
            }
            self.count += 1;
        }
    }
}

/// The arc for an open piece (junction to junction), found forwards or reversed, or new.
fn open_arc(arcs: &mut Vec<Arc>, open: &mut HashMap<Vec<usize>, usize>, piece: &[usize]) -> ArcUse {
    if let Some(&arc) = open.get(piece) {
        return ArcUse {
            arc,
            reversed: false,
        };
    }
    let rev: Vec<usize> = piece.iter().rev().copied().collect();
    if let Some(&arc) = open.get(&rev) {
        return ArcUse {
            arc,
            reversed: true,
        };
    }
    arcs.push(Arc {
        vertices: piece.to_vec(),
        closed: false,
        uses: 0,
    });
    open.insert(piece.to_vec(), arcs.len() - 1);
    ArcUse {
        arc: arcs.len() - 1,
        reversed: false,
    }
}

/// A cycle started at its smallest vertex, run towards its smaller neighbour; and whether that
/// is against the cycle's own direction.
fn canonical_cycle(cyc: &[usize]) -> (Vec<usize>, bool) {
    let n = cyc.len();
    let m = (0..n).min_by_key(|&i| cyc[i]).expect("non-empty cycle");
    let (next, prev) = (cyc[(m + 1) % n], cyc[(m + n - 1) % n]);
    let reversed = prev < next;
    let key = (0..n)
        .map(|k| {
            if reversed {
                cyc[(m + n - k) % n]
            } else {
                cyc[(m + k) % n]
            }
        })
        .collect();
    (key, reversed)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::earth::lonlat_to_unit;

    fn ring(ll: &[(f64, f64)]) -> InputRing {
        let mut points: Vec<[f64; 3]> = ll.iter().map(|&(a, b)| lonlat_to_unit(a, b)).collect();
        points.push(points[0]);
        InputRing { points }
    }

    /// Two unit squares side by side, sharing the edge x = 1 (three vertices on it).
    fn two_squares(shift_right: f64) -> Vec<InputRing> {
        vec![
            ring(&[(0.0, 0.0), (1.0, 0.0), (1.0, 0.5), (1.0, 1.0), (0.0, 1.0)]),
            // Counterclockwise too, so it runs the shared edge the other way.
            ring(&[
                (1.0 + shift_right, 0.0),
                (2.0, 0.0),
                (2.0, 1.0),
                (1.0 + shift_right, 1.0),
                (1.0 + shift_right, 0.5),
            ]),
        ]
    }

    /// The vertex rule of [`Snapper`] as first written: the 27 fine cells around a position
    /// looked up in order, the first vertex within the radius in the first cell holding one.
    fn snap_by_fine_cells(points: &[[f64; 3]]) -> Vec<usize> {
        let mut cells: std::collections::HashMap<[i64; 3], Vec<usize>> = Default::default();
        let mut vertices: Vec<[f64; 3]> = Vec::new();
        let mut ids = Vec::new();
        'points: for p in points {
            let c = Snapper::fine_cell(p);
            for dx in -1..=1 {
                for dy in -1..=1 {
                    for dz in -1..=1 {
                        let found = cells.get(&[c[0] + dx, c[1] + dy, c[2] + dz]).and_then(|v| {
                            v.iter()
                                .find(|&&i| angle_between(&vertices[i], p) <= SHARED_VERTEX_RAD)
                        });
                        if let Some(&i) = found {
                            ids.push(i);
                            continue 'points;
                        }
                    }
                }
            }
            ids.push(vertices.len());
            cells.entry(c).or_default().push(vertices.len());
            vertices.push(*p);
        }
        ids
    }

    #[test]
    fn floor_without_a_call_is_floor() {
        for y in [
            0.0,
            -0.0,
            0.5,
            -0.5,
            1.0,
            -1.0,
            2.9999,
            -2.0001,
            1e10 + 0.5,
            -1e10 - 0.5,
            f64::MIN_POSITIVE,
            -f64::MIN_POSITIVE,
            1e300,
            -1e300,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
        ] {
            assert_eq!(floor_i64(y), y.floor() as i64, "{y}");
        }
    }

    #[test]
    fn coarse_cells_snap_as_the_27_fine_cells_did() {
        // Clusters of positions a few radii across, some around a corner shared by coarse
        // cells, so a position often has several vertices within the radius to choose from.
        let coarse = SHARED_VERTEX_RAD * COARSE_CELL;
        let mut seed = 7u64;
        let mut uniform = || {
            seed = seed
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut points = Vec::new();
        for k in 0..40 {
            let centre =
                crate::earth::lonlat_to_unit(3.0 * f64::from(k) - 60.0, 0.7 * f64::from(k) - 14.0);
            // Half the clusters on a coarse corner.
            let centre = if k % 2 == 0 {
                centre.map(|x| (x / coarse).round() * coarse)
            } else {
                centre
            };
            for _ in 0..200 {
                let p = centre.map(|x| x + (uniform() - 0.5) * 6.0 * SHARED_VERTEX_RAD);
                let n = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
                points.push(p.map(|x| x / n));
            }
        }
        let mut snap = Snapper::with_capacity(points.len());
        let ids: Vec<usize> = points.iter().map(|p| snap.vertex(p)).collect();
        let expected = snap_by_fine_cells(&points);
        assert_eq!(ids, expected);
        // Vertices were merged, and not all into one per cluster.
        let distinct = snap.vertices.len();
        assert!(distinct < points.len() / 2 && distinct > 40, "{distinct}");
    }

    #[test]
    fn a_shared_border_is_one_arc_used_reversed() {
        let g = ArcGraph::build(&two_squares(0.0));
        // Junctions at (1, 0) and (1, 1): the shared edge, and the two outer pieces.
        assert_eq!(g.junctions, 2);
        assert_eq!(g.arcs.len(), 3);
        let shared: Vec<usize> = (0..3).filter(|&a| g.arcs[a].uses == 2).collect();
        assert_eq!(shared.len(), 1);
        let s = shared[0];
        assert_eq!(g.arcs[s].vertices.len(), 3);
        let in_a = g.rings[0].iter().find(|u| u.arc == s).unwrap();
        let in_b = g.rings[1].iter().find(|u| u.arc == s).unwrap();
        assert_ne!(in_a.reversed, in_b.reversed);
        // Every ring's arcs chain end to start and close.
        for uses in &g.rings {
            let ends: Vec<(usize, usize)> = uses
                .iter()
                .map(|u| {
                    let v = &g.arcs[u.arc].vertices;
                    if u.reversed {
                        (v[v.len() - 1], v[0])
                    } else {
                        (v[0], v[v.len() - 1])
                    }
                })
                .collect();
            for k in 0..ends.len() {
                assert_eq!(ends[k].1, ends[(k + 1) % ends.len()].0);
            }
        }
    }

    #[test]
    fn near_matches_snap_within_the_epsilon_and_not_beyond() {
        // 1e-11 rad (0.06 mm) apart: the same vertices, so the border is shared.
        let g = ArcGraph::build(&two_squares(1e-11f64.to_degrees()));
        assert_eq!(g.arcs.iter().filter(|a| a.uses == 2).count(), 1);
        assert_eq!(g.vertices.len(), 7);
        // 1e-9 rad (6 mm) apart: distinct vertices, nothing shared, each ring one closed arc.
        let g = ArcGraph::build(&two_squares(1e-9f64.to_degrees()));
        assert_eq!(g.arcs.iter().filter(|a| a.uses == 2).count(), 0);
        assert_eq!(g.arcs.len(), 2);
        assert!(g.arcs.iter().all(|a| a.closed));
        assert_eq!(g.vertices.len(), 10);
    }

    #[test]
    fn an_enclave_is_one_closed_arc_used_by_its_shell_and_the_hole() {
        let hole = [(0.4, 0.4), (0.6, 0.4), (0.6, 0.6), (0.4, 0.6)];
        // The enclave's shell starts elsewhere and runs the other way.
        let shell = [(0.6, 0.6), (0.6, 0.4), (0.4, 0.4), (0.4, 0.6)];
        let g = ArcGraph::build(&[
            ring(&[(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]),
            ring(&hole),
            ring(&shell),
        ]);
        assert_eq!(g.junctions, 0);
        assert_eq!(g.arcs.len(), 2);
        assert_eq!(g.rings[1][0].arc, g.rings[2][0].arc);
        assert!(g.arcs[g.rings[1][0].arc].closed);
        assert_eq!(g.arcs[g.rings[1][0].arc].uses, 2);
        // hole runs counterclockwise like `shell` reversed, so exactly one is reversed.
        assert_ne!(g.rings[1][0].reversed, g.rings[2][0].reversed);
    }

    #[test]
    fn three_features_meeting_make_a_junction_of_three() {
        // A square cut into a left half and two right quarters.
        let g = ArcGraph::build(&[
            ring(&[(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (1.0, 2.0), (0.0, 2.0)]),
            ring(&[(1.0, 0.0), (2.0, 0.0), (2.0, 1.0), (1.0, 1.0)]),
            ring(&[(1.0, 1.0), (2.0, 1.0), (2.0, 2.0), (1.0, 2.0)]),
        ]);
        // (1,1) joins three rings; (1,0), (1,2), (2,1) are where a border meets the outside.
        assert_eq!(g.junctions, 4);
        assert_eq!(g.arcs.iter().filter(|a| a.uses == 2).count(), 3);
        assert_eq!(g.arcs.iter().filter(|a| a.uses == 1).count(), 3);
        // Antimeridian and pole: 180 and -180 are one vertex, as is every longitude at a pole.
        let g = ArcGraph::build(&[ring(&[(180.0, 10.0), (-170.0, 10.0), (-180.0, 10.0)])]);
        assert_eq!(g.vertices.len(), 2);
        assert_eq!(g.short_rings, vec![0]);
        let g = ArcGraph::build(&[ring(&[
            (0.0, 80.0),
            (10.0, 90.0),
            (-20.0, 90.0),
            (40.0, 80.0),
        ])]);
        assert_eq!(g.vertices.len(), 3);
    }
}
