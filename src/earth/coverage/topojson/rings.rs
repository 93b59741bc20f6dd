//! Rings that were not rebuilt from arcs, written with the coverage's arcs all the same.
//!
//! A polygon cut at ±180 (Russia, Fiji, Antarctica) or holding a ring kept small (an islet
//! whose fit bounds no area) is written from its output coordinates, not from arc uses. Given an
//! arc of its own per ring, such a feature repeated every border it shares with its neighbours,
//! and the coverage arcs its rings were made of stayed in the file with no geometry using them:
//! on the world-atlas 50m countries at 1 km, 255 unused arcs (8,597 positions, 13 % of the
//! file's) plus 9,896 positions of arcs of their own.
//!
//! Here such a ring is matched against the coverage's arcs on the quantised grid, where shared
//! positions are identical integers: wherever the ring runs along a whole arc (either way) it
//! uses that arc, and only what is left (the steps to and along the antimeridian, the part of an
//! arc the cut divided, a ring kept small) becomes arcs of its own. Matching whole arcs only
//! keeps the topology's rule that arcs meet at their ends.

use std::collections::HashMap;

/// A grid position: TopoJSON's quantised `[x, y]`.
pub type Cell = [i64; 2];

/// One piece of a ring: a coverage arc (TopoJSON's index, `!k` when run backwards) or
/// positions of its own (at least two, the first and last shared with the pieces around it).
#[derive(Clone, Debug, PartialEq)]
pub enum Piece {
    Arc(i64),
    Own(Vec<Cell>),
}

/// The coverage's arcs, found by their first step.
pub struct ArcIndex<'a> {
    arcs: &'a [Vec<Cell>],
    /// `(first, second)` position of an arc run forwards, or of one run backwards, to the
    /// arcs (and direction) starting so.
    starts: HashMap<(Cell, Cell), Vec<(usize, bool)>>,
}

impl<'a> ArcIndex<'a> {
    /// Indexes `arcs` (grid positions each). Arcs with no step (one position, or every
    /// position the same after rounding) are never matched.
    pub fn new(arcs: &'a [Vec<Cell>]) -> ArcIndex<'a> {
        let mut starts: HashMap<(Cell, Cell), Vec<(usize, bool)>> = HashMap::new();
        for (k, a) in arcs.iter().enumerate() {
            if a.len() < 2 || a.windows(2).any(|w| w[0] == w[1]) {
                continue;
            }
            let m = a.len();
            starts.entry((a[0], a[1])).or_default().push((k, false));
            starts
                .entry((a[m - 1], a[m - 2]))
                .or_default()
                .push((k, true));
        }
        ArcIndex { arcs, starts }
    }

    /// The longest arc that the cyclic ring `r` runs along from position `i`: its TopoJSON
    /// index and the ring steps it covers (at most `steps_left`).
    fn match_at(&self, r: &[Cell], i: usize, steps_left: usize) -> Option<(i64, usize)> {
        let n = r.len();
        let key = (r[i], r[(i + 1) % n]);
        let mut best: Option<(i64, usize)> = None;
        for &(k, reversed) in self.starts.get(&key).map(Vec::as_slice).unwrap_or(&[]) {
            let a = &self.arcs[k];
            let steps = a.len() - 1;
            if steps > steps_left || best.is_some_and(|(_, s)| s >= steps) {
                continue;
            }
            let at = |j: usize| if reversed { a[steps - j] } else { a[j] };
            if (0..=steps).all(|j| at(j) == r[(i + j) % n]) {
                let index = if reversed { !(k as i64) } else { k as i64 };
                best = Some((index, steps));
            }
        }
        best
    }

    /// Ring `ring` (closed: its last position repeats its first) as pieces in ring order:
    /// whole coverage arcs where it runs along them, positions of its own between. A ring
    /// that runs along no arc is one piece of its own, as written.
    pub fn pieces(&self, ring: &[Cell]) -> Vec<Piece> {
        let mut r: &[Cell] = ring;
        if r.len() > 1 && r.first() == r.last() {
            r = &r[..r.len() - 1];
        }
        let n = r.len();
        let whole = || vec![Piece::Own(ring.to_vec())];
        // A ring of under three positions cannot run along an arc (arcs of a ring have steps).
        if n < 3 {
            return whole();
        }
        let Some((start, _)) = (0..n).find_map(|i| self.match_at(r, i, n).map(|m| (i, m))) else {
            return whole();
        };
        let mut out = Vec::new();
        let mut own: Vec<Cell> = Vec::new();
        let (mut pos, mut done) = (start, 0);
        while done < n {
            if let Some((index, steps)) = self.match_at(r, pos, n - done) {
                // A run of its own already ends at this position, where the arc starts.
                if !own.is_empty() {
                    out.push(Piece::Own(std::mem::take(&mut own)));
                }
                out.push(Piece::Arc(index));
                pos = (pos + steps) % n;
                done += steps;
            } else {
                if own.is_empty() {
                    own.push(r[pos]);
                }
                pos = (pos + 1) % n;
                own.push(r[pos]);
                done += 1;
            }
        }
        if !own.is_empty() {
            out.push(Piece::Own(own));
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cells(xs: &[(i64, i64)]) -> Vec<Cell> {
        xs.iter().map(|&(x, y)| [x, y]).collect()
    }

    #[test]
    fn a_ring_along_arcs_uses_them_and_keeps_the_rest_as_its_own() {
        // Two arcs: a border (0,0)->(2,0)->(4,0), and an island's closed arc.
        let arcs = vec![
            cells(&[(0, 0), (2, 0), (4, 0)]),
            cells(&[(10, 10), (11, 10), (11, 11), (10, 10)]),
        ];
        let index = ArcIndex::new(&arcs);
        // A ring cut at an antimeridian-like edge: along the border backwards, then its own
        // steps (4,0) -> (4,3) -> (0,3) -> (0,0); it starts in the middle of its own part.
        let ring = cells(&[(4, 3), (0, 3), (0, 0), (2, 0), (4, 0), (4, 3)]);
        let pieces = index.pieces(&ring);
        assert_eq!(
            pieces,
            vec![
                Piece::Arc(0),
                Piece::Own(cells(&[(4, 0), (4, 3), (0, 3), (0, 0)])),
            ]
        );
        // The same ring the other way round runs the border backwards.
        let reversed: Vec<Cell> = ring.iter().rev().copied().collect();
        assert_eq!(
            index.pieces(&reversed),
            vec![
                Piece::Arc(!0),
                Piece::Own(cells(&[(0, 0), (0, 3), (4, 3), (4, 0)])),
            ]
        );
        // An island starting elsewhere on its closed arc is that arc.
        let island = cells(&[(11, 10), (11, 11), (10, 10), (11, 10)]);
        assert_eq!(index.pieces(&island), vec![Piece::Arc(1)]);
    }

    #[test]
    fn a_ring_along_part_of_an_arc_only_is_its_own() {
        let arcs = vec![cells(&[(0, 0), (2, 0), (4, 0), (6, 0)])];
        let index = ArcIndex::new(&arcs);
        // Runs (0,0)->(2,0)->(4,0) but leaves the arc before its end: not the whole arc.
        let ring = cells(&[(0, 0), (2, 0), (4, 0), (4, 5), (0, 0)]);
        assert_eq!(index.pieces(&ring), vec![Piece::Own(ring.clone())]);
        // Too short to run along anything.
        let tiny = cells(&[(0, 0), (2, 0), (0, 0)]);
        assert_eq!(index.pieces(&tiny), vec![Piece::Own(tiny.clone())]);
    }

    #[test]
    fn pieces_join_end_to_end_and_give_the_ring_back() {
        let arcs = vec![
            cells(&[(0, 0), (1, 0), (2, 0)]),
            cells(&[(2, 0), (2, 1), (2, 2)]),
            cells(&[(0, 2), (0, 1), (0, 0)]),
        ];
        let index = ArcIndex::new(&arcs);
        let ring = cells(&[
            (0, 0),
            (1, 0),
            (2, 0),
            (2, 1),
            (2, 2),
            (1, 2),
            (0, 2),
            (0, 1),
            (0, 0),
        ]);
        let pieces = index.pieces(&ring);
        assert_eq!(pieces.len(), 4, "{pieces:?}");
        // Decode as a TopoJSON reader: each piece's first position is the last one before.
        let mut out: Vec<Cell> = Vec::new();
        for p in &pieces {
            let ps: Vec<Cell> = match p {
                Piece::Arc(k) if *k >= 0 => arcs[*k as usize].clone(),
                Piece::Arc(k) => arcs[!*k as usize].iter().rev().copied().collect(),
                Piece::Own(ps) => ps.clone(),
            };
            if let Some(last) = out.last() {
                assert_eq!(*last, ps[0], "{pieces:?}");
                out.extend_from_slice(&ps[1..]);
            } else {
                out.extend_from_slice(&ps);
            }
        }
        assert_eq!(out.first(), out.last());
        assert_eq!(out.len(), ring.len(), "{pieces:?} -> {out:?}");
        // The same cycle of positions.
        let start = ring.iter().position(|c| *c == out[0]).unwrap();
        let n = ring.len() - 1;
        for j in 0..n {
            assert_eq!(out[j], ring[(start + j) % n]);
        }
    }
}
