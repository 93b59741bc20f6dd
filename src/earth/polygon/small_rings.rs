//! Rings that collapse: what a polygon ring becomes when it is too small to fit.
//!
//! A ring narrower than the tolerance (an islet, a sliver hole) can fit to a curve of one or two
//! distinct points, and a ring of one repeated position (Natural Earth writes such islets) cannot
//! be fitted at all. Written as they come, both give rings that RFC 7946 forbids (fewer than four
//! positions) or that bound no area, and refusing them would refuse the whole feature. So such a
//! ring is kept, as mapshaper's `keep-shapes` keeps it: as the triangle of three of its own
//! positions that spans it (with more of its positions where an input position would be farther
//! than the tolerance from the triangle), or as it came when it has fewer than three distinct
//! positions. Its
//! report says so (`small_ring`), with its distance to the input measured, not assumed.
//!
//! With `drop_small_rings` ([`crate::earth::Job::drop_small_rings`]) such a ring is dropped
//! instead ([`drop_kept`] per feature; the shared fit does the same with its arcs) and its
//! pointer listed in `properties.fit.dropped_rings`. A polygon whose exterior ring is dropped
//! goes whole, its holes with it (a hole without its exterior bounds nothing); a feature left
//! with no polygon is still written, with its properties, `id` and report, and an empty
//! MultiPolygon (`"coordinates": []`) as its geometry: the feature is never refused or lost,
//! and a GIS reads it as an empty geometry of the layer's type.

use serde_json::{json, Map, Value};

use crate::earth::curve::output::{CurveOutput, CurveReport};
use crate::earth::curve::positions::{parse_positions, LinePositions};
use crate::earth::error::EarthError;
use crate::earth::json_out::JsonOut;
use crate::earth::lonlat::{rad_to_m, round_to, unit_to_lonlat};
use crate::sphere::geometry::arc::distance_to_arc;

/// Samples per triangle edge when the triangle's distance to the input outline is measured.
const EDGE_SAMPLES: usize = 32;

/// The distinct positions of a ring as written at `precision` decimals, the closing repeat and
/// consecutive repeats not counted; stops counting at 3 (all a caller needs to know).
fn distinct_written(points: &[[f64; 3]], precision: u32) -> usize {
    let mut seen: Vec<(f64, f64)> = Vec::with_capacity(3);
    for p in points {
        let (lon, lat) = unit_to_lonlat(p);
        let q = (round_to(lon, precision), round_to(lat, precision));
        if !seen.contains(&q) {
            seen.push(q);
            if seen.len() == 3 {
                break;
            }
        }
    }
    seen.len()
}

/// Whether a fitted ring has collapsed: fewer than 4 positions, or fewer than 3 distinct ones
/// once rounded for output, so that it would bound no area.
pub fn collapsed(out: &CurveOutput, precision: u32) -> bool {
    out.points.len() < 4 || distinct_written(&out.points, precision) < 3
}

/// The indices of three input positions spanning the ring (in ring order), or `None` when the
/// ring has fewer than three distinct positions: the first, the farthest from it, and the
/// farthest from the great circle through those two.
fn spanning_triangle(points: &[[f64; 3]]) -> Option<[usize; 3]> {
    let a = 0;
    let pa = points.first()?;
    let dist2 = |p: &[f64; 3], q: &[f64; 3]| (0..3).map(|k| (p[k] - q[k]).powi(2)).sum::<f64>();
    let (b, db) = points
        .iter()
        .enumerate()
        .map(|(i, p)| (i, dist2(pa, p)))
        .fold((0, 0.0), |m, x| if x.1 > m.1 { x } else { m });
    if db == 0.0 {
        return None;
    }
    let pb = &points[b];
    let n = [
        pa[1] * pb[2] - pa[2] * pb[1],
        pa[2] * pb[0] - pa[0] * pb[2],
        pa[0] * pb[1] - pa[1] * pb[0],
    ];
    let (c, dc) = points
        .iter()
        .enumerate()
        .map(|(i, p)| (i, (n[0] * p[0] + n[1] * p[1] + n[2] * p[2]).abs()))
        .fold((0, 0.0), |m, x| if x.1 > m.1 { x } else { m });
    if dc == 0.0 {
        return None;
    }
    let mut idx = [a, b, c];
    idx.sort_unstable();
    Some(idx)
}

/// The input positions a kept ring is written with (indices into `points`, in ring order,
/// closed): the spanning triangle, then, while some input position is farther than
/// `tolerance_rad` from the edge of the span it lies in, that farthest position too (as
/// Douglas–Peucker adds them), so that an islet wider than a triangle allows comes back within
/// the tolerance with as few of its own positions as that needs. `None` when the ring has fewer
/// than three distinct positions.
pub(crate) fn kept_indices(points: &[[f64; 3]], tolerance_rad: Option<f64>) -> Option<Vec<usize>> {
    let [a, b, c] = spanning_triangle(points)?;
    let last = points.len() - 1;
    // The closing repeat (if any) is the first position again: spans run to `end`.
    let end = if points[last] == points[0] {
        last
    } else {
        points.len()
    };
    let mut idx = vec![a, b, c];
    if let Some(tol) = tolerance_rad {
        loop {
            // The farthest position from the edge of its span, over every span.
            let mut worst: Option<(f64, usize, usize)> = None;
            for k in 0..idx.len() {
                let (i, j) = (
                    idx[k],
                    if k + 1 < idx.len() {
                        idx[k + 1]
                    } else {
                        idx[0] + end
                    },
                );
                for m in i + 1..j {
                    let q = &points[m % end];
                    let d = distance_to_arc(q, &points[i % end], &points[j % end]);
                    if d > tol && worst.is_none_or(|w| d > w.0) {
                        worst = Some((d, m % end, k + 1));
                    }
                }
            }
            match worst {
                Some((_, m, at)) => {
                    // Positions past the last kept one wrap round: keep ring order.
                    if m < idx[0] {
                        idx.insert(0, m);
                    } else {
                        idx.insert(at, m);
                    }
                }
                None => break,
            }
        }
    }
    idx.push(idx[0]);
    Some(idx)
}

/// Largest distance (radians) from any of `from` to the closed outline through `ring`.
fn max_distance_to_outline(from: &[[f64; 3]], ring: &[[f64; 3]]) -> f64 {
    from.iter()
        .map(|q| {
            ring.windows(2)
                .map(|w| distance_to_arc(q, &w[0], &w[1]))
                .fold(f64::INFINITY, f64::min)
        })
        .fold(0.0, f64::max)
}

/// Points along the closed outline through `ring`: its vertices and `EDGE_SAMPLES` per edge.
fn outline_samples(ring: &[[f64; 3]]) -> Vec<[f64; 3]> {
    let mut out = Vec::new();
    for w in ring.windows(2) {
        for k in 0..EDGE_SAMPLES {
            let t = k as f64 / EDGE_SAMPLES as f64;
            let p: Vec<f64> = (0..3).map(|d| w[0][d] * (1.0 - t) + w[1][d] * t).collect();
            let norm = p.iter().map(|x| x * x).sum::<f64>().sqrt();
            if norm > 0.0 {
                out.push([p[0] / norm, p[1] / norm, p[2] / norm]);
            }
        }
    }
    out
}

/// Whether a ring of lon/lat positions (closed, as written) has collapsed: fewer than 4
/// positions or fewer than 3 distinct ones.
pub fn collapsed_lonlat(ring: &[[f64; 2]]) -> bool {
    if ring.len() < 4 {
        return true;
    }
    let mut seen: Vec<[f64; 2]> = Vec::with_capacity(3);
    for p in ring {
        if !seen.contains(p) {
            seen.push(*p);
            if seen.len() == 3 {
                return false;
            }
        }
    }
    true
}

/// A ring (unit vectors, as it came) kept as lon/lat positions rounded at `precision`: the
/// closed triangle of three of its positions, or all its positions when it has fewer than
/// three distinct ones.
pub fn kept_lonlat(
    points: &[[f64; 3]],
    tolerance_rad: Option<f64>,
    precision: u32,
) -> (Vec<[f64; 2]>, Kept) {
    let (idx, how): (Vec<usize>, Kept) = match kept_indices(points, tolerance_rad) {
        Some(idx) => (idx, Kept::Triangle),
        None => ((0..points.len()).collect(), Kept::Input),
    };
    let ring = idx
        .iter()
        .map(|&i| {
            let (lon, lat) = unit_to_lonlat(&points[i]);
            [round_to(lon, precision), round_to(lat, precision)]
        })
        .collect();
    (ring, how)
}

/// The two-way distance (radians) between a ring's input positions and the ring written for it
/// (`kept`, lon/lat as [`kept_lonlat`] rounds them), measured as [`keep`] measures a per-feature
/// kept ring: input positions to the written outline exactly, the outline's edges by samples
/// against the input's. A shared-topology fit counts it in its feature's bound: before
/// 2026-12-05 it did not, and a Croatian islet of the 10m countries at 1 km came back 981 m
/// from its triangle under a feature bound of 749 m.
pub fn kept_two_way_rad(points: &[[f64; 3]], kept: &[[f64; 2]]) -> f64 {
    let outline: Vec<[f64; 3]> = kept
        .iter()
        .map(|p| crate::earth::lonlat::lonlat_to_unit(p[0], p[1]))
        .collect();
    if outline.is_empty() {
        return 0.0;
    }
    let forward = max_distance_to_outline(points, &outline);
    let back = max_distance_to_outline(&outline_samples(&outline), points);
    forward.max(back)
}

/// How a kept ring is written.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kept {
    /// The triangle of three of its positions, with more of them where the tolerance needs
    /// them (`kept_indices`).
    Triangle,
    /// Its positions as they came (fewer than three distinct ones).
    Input,
}

impl Kept {
    /// The name the report gives it (`small_ring`).
    pub fn name(self) -> &'static str {
        match self {
            Kept::Triangle => "kept_as_triangle",
            Kept::Input => "kept_as_input",
        }
    }
}

/// The ring at `pointer` (input `value`) kept as a triangle of its own positions or as it
/// came, with a report of the same shape as a fitted ring's: a degree-1 spline through the
/// kept positions, and its distances to the input measured both ways.
///
/// # Errors
/// The ring's positions are invalid (the same errors as a fit gives).
pub fn keep(
    value: &Value,
    pointer: &str,
    path: Vec<usize>,
    tolerance_m: Option<f64>,
) -> Result<(CurveOutput, Kept), EarthError> {
    let line: LinePositions = parse_positions(value, pointer)?;
    let tolerance_rad = tolerance_m.map(crate::earth::lonlat::m_to_rad);
    let (kept_idx, how): (Vec<usize>, Kept) = match kept_indices(&line.points, tolerance_rad) {
        Some(idx) => (idx, Kept::Triangle),
        None => ((0..line.points.len()).collect(), Kept::Input),
    };
    let points: Vec<[f64; 3]> = kept_idx.iter().map(|&i| line.points[i]).collect();
    let alts: Vec<f64> = match &line.alts {
        Some(a) => kept_idx.iter().map(|&i| a[i]).collect(),
        None => vec![0.0; points.len()],
    };
    // Input to outline exactly (vertex to great-circle edge); outline to input by samples of
    // the triangle's edges against the input's edges.
    let (one_way, two_way) = if how == Kept::Triangle {
        let forward = max_distance_to_outline(&line.points, &points);
        let back = max_distance_to_outline(&outline_samples(&points), &line.points);
        (forward, forward.max(back))
    } else {
        (0.0, 0.0)
    };
    let errors: Vec<f64> = if how == Kept::Triangle {
        line.points
            .iter()
            .map(|q| max_distance_to_outline(std::slice::from_ref(q), &points))
            .collect()
    } else {
        vec![0.0; line.points.len()]
    };
    let n = line.points.len().max(1) as f64;
    let sum_m: f64 = errors.iter().map(|&e| rad_to_m(e)).sum();
    let sq_m2: f64 = errors.iter().map(|&e| rad_to_m(e).powi(2)).sum();
    let ncp = points.len();
    let knots: Vec<f64> = std::iter::once(0.0)
        .chain((0..ncp).map(|i| i as f64 / (ncp.max(2) - 1) as f64))
        .chain(std::iter::once(1.0))
        .collect();
    let has_alt = line.alts.is_some();
    let control_points: Vec<Value> = points
        .iter()
        .zip(&alts)
        .map(|(p, z)| {
            let (lon, lat) = unit_to_lonlat(p);
            if has_alt {
                json!([lon, lat, z])
            } else {
                json!([lon, lat])
            }
        })
        .collect();
    let stored = ncp * if has_alt { 3 } else { 2 } + 1;
    let max_m = round_to(rad_to_m(one_way), 3);
    let mut fields = Map::new();
    fields.insert("small_ring".into(), json!(how.name()));
    fields.insert("degree".into(), json!(1));
    fields.insert("control_points".into(), json!(ncp));
    fields.insert("converged".into(), json!(true));
    fields.insert("iterations".into(), json!(0));
    fields.insert("input_points".into(), json!(line.points.len()));
    fields.insert("output_points".into(), json!(ncp));
    fields.insert("max_error_m".into(), json!(max_m));
    fields.insert("mean_error_m".into(), json!(round_to(sum_m / n, 3)));
    fields.insert("rms_error_m".into(), json!(round_to((sq_m2 / n).sqrt(), 3)));
    fields.insert("sampling_deviation_m".into(), json!(0.0));
    fields.insert("stored_numbers".into(), json!(stored));
    if let Some(t) = tolerance_m {
        let two_way_m = rad_to_m(two_way);
        fields.insert("tolerance_m".into(), json!(t));
        fields.insert("tolerance_met".into(), json!(two_way_m <= t));
        fields.insert(
            "two_way_distance_m".into(),
            json!((two_way_m * 1000.0).ceil() / 1000.0),
        );
    }
    let spline = JsonOut::Value(json!({
        "degree": 1,
        "knots": knots,
        "control_points": control_points,
    }));
    let report = CurveReport {
        path,
        closed: true,
        fields,
        spline: Some(spline),
        input_points: line.points.len(),
        output_points: ncp,
        stored_numbers: stored,
        max_error_m: max_m,
        error_sum_m: sum_m,
        error_sq_sum_m2: sq_m2,
    };
    Ok((
        CurveOutput {
            pointer: pointer.to_string(),
            points,
            alts,
            has_alt,
            report,
            time: None,
            kept: None,
        },
        how,
    ))
}

/// Takes the rings kept as small (those whose report has `small_ring`) out of `outputs`, with
/// the other rings of a polygon whose exterior ring is one of them, and returns the pointers of
/// the rings taken, in input order. `outputs` are the rings of one Polygon (paths `[ring]`) or
/// MultiPolygon (paths `[polygon, ring]`).
pub fn drop_kept(outputs: &mut Vec<CurveOutput>) -> Vec<String> {
    let small = |c: &CurveOutput| c.report.fields.contains_key("small_ring");
    let polygon = |c: &CurveOutput| c.report.path[..c.report.path.len().saturating_sub(1)].to_vec();
    let gone: Vec<Vec<usize>> = outputs
        .iter()
        .filter(|c| small(c) && c.report.path.last() == Some(&0))
        .map(polygon)
        .collect();
    let mut dropped = Vec::new();
    outputs.retain(|c| {
        let drop = small(c) || gone.contains(&polygon(c));
        if drop {
            dropped.push(c.pointer.clone());
        }
        !drop
    });
    dropped
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::earth::lonlat_to_unit;

    fn ring(ps: &[[f64; 2]]) -> Value {
        json!(ps)
    }

    #[test]
    fn a_ring_of_one_repeated_position_is_kept_as_it_came() {
        let v = ring(&[[5.0, 40.0], [5.0, 40.0], [5.0, 40.0], [5.0, 40.0]]);
        let (out, how) = keep(&v, "/coordinates/1/0", vec![1, 0], Some(100.0)).unwrap();
        assert_eq!(how, Kept::Input);
        assert_eq!(out.points.len(), 4);
        assert_eq!(out.report.fields["tolerance_met"], json!(true));
        assert_eq!(out.report.fields["small_ring"], json!("kept_as_input"));
    }

    #[test]
    fn a_kept_ring_takes_as_many_of_its_positions_as_the_tolerance_needs() {
        // A square islet of about 22 km: its spanning triangle leaves a corner 15 km out.
        let ps = [
            [10.0, 50.0],
            [10.1, 50.0],
            [10.2, 50.0],
            [10.3, 50.0],
            [10.3, 50.1],
            [10.3, 50.2],
            [10.15, 50.2],
            [10.0, 50.2],
            [10.0, 50.1],
            [10.0, 50.0],
        ];
        let input: Vec<[f64; 3]> = ps.iter().map(|p| lonlat_to_unit(p[0], p[1])).collect();
        let triangle = kept_indices(&input, None).unwrap();
        assert_eq!(triangle.len(), 4);
        let outline: Vec<[f64; 3]> = triangle.iter().map(|&i| input[i]).collect();
        let loose = rad_to_m(max_distance_to_outline(&input, &outline));
        assert!(loose > 10_000.0, "{loose}");
        let (out, how) = keep(&ring(&ps), "/coordinates/0", vec![0], Some(1000.0)).unwrap();
        assert_eq!(how, Kept::Triangle);
        assert_eq!(out.points.len(), 5, "the fourth corner added");
        assert_eq!(out.points[0], out.points[4]);
        let d = rad_to_m(max_distance_to_outline(&input, &out.points));
        assert!(d <= 1000.0, "{d}");
        assert_eq!(out.report.fields["tolerance_met"], json!(true));
        // The same in shared mode's lon/lat form.
        let (ll, _) = kept_lonlat(&input, Some(crate::earth::lonlat::m_to_rad(1000.0)), 7);
        assert_eq!(ll.len(), 5);
    }

    #[test]
    fn a_narrow_ring_is_kept_as_a_closed_triangle_of_its_positions() {
        let ps = [
            [8.0, 40.0],
            [8.001, 40.0],
            [8.003, 40.0],
            [8.003, 40.0002],
            [8.0, 40.0002],
            [8.0, 40.0],
        ];
        let (out, how) = keep(&ring(&ps), "/coordinates/0", vec![0], Some(1000.0)).unwrap();
        assert_eq!(how, Kept::Triangle);
        assert_eq!(out.points.len(), 4);
        assert_eq!(out.points[0], out.points[3]);
        let input: Vec<[f64; 3]> = ps.iter().map(|p| lonlat_to_unit(p[0], p[1])).collect();
        for p in &out.points {
            assert!(input.contains(p), "a kept vertex is an input vertex");
        }
        assert!(!collapsed(&out, 7));
        // The ring is about 22 m across: every input vertex is within that of the triangle.
        let two_way = out.report.fields["two_way_distance_m"].as_f64().unwrap();
        assert!(two_way > 0.0 && two_way < 30.0, "{two_way}");
    }

    #[test]
    fn dropping_an_exterior_drops_its_holes_and_nothing_else() {
        let square = json!([[0, 0], [1, 0], [1, 1], [0, 1], [0, 0]]);
        let tiny = json!([[5.0, 40.0], [5.0, 40.0], [5.0, 40.0], [5.0, 40.0]]);
        let ring = |v: &Value, path: Vec<usize>, small: bool| {
            let pointer = format!(
                "/coordinates/{}",
                path.iter()
                    .map(|i| i.to_string())
                    .collect::<Vec<_>>()
                    .join("/")
            );
            let (mut out, _) = keep(v, &pointer, path, None).unwrap();
            if !small {
                out.report.fields.remove("small_ring");
            }
            out
        };
        // Polygon 0: a kept exterior with a hole; polygon 1: an exterior with a small hole;
        // polygon 2: untouched.
        let mut outputs = vec![
            ring(&tiny, vec![0, 0], true),
            ring(&square, vec![0, 1], false),
            ring(&square, vec![1, 0], false),
            ring(&tiny, vec![1, 1], true),
            ring(&square, vec![2, 0], false),
        ];
        let dropped = drop_kept(&mut outputs);
        assert_eq!(
            dropped,
            ["/coordinates/0/0", "/coordinates/0/1", "/coordinates/1/1"]
        );
        let left: Vec<Vec<usize>> = outputs.iter().map(|c| c.report.path.clone()).collect();
        assert_eq!(left, [vec![1, 0], vec![2, 0]]);
    }

    #[test]
    fn collapse_is_judged_on_the_written_positions() {
        let p = lonlat_to_unit(10.0, 40.0);
        let q = lonlat_to_unit(10.00000001, 40.0);
        let r = lonlat_to_unit(10.0, 40.00000001);
        let out = |points: Vec<[f64; 3]>| CurveOutput {
            pointer: String::new(),
            alts: vec![0.0; points.len()],
            points,
            has_alt: false,
            report: keep(&json!([[0, 0], [1, 0], [0, 1], [0, 0]]), "", vec![], None)
                .unwrap()
                .0
                .report,
            time: None,
            kept: None,
        };
        assert!(collapsed(&out(vec![p, q, p]), 7));
        assert!(collapsed(&out(vec![p, q, r, p]), 7), "equal at 7 decimals");
        assert!(!collapsed(&out(vec![p, q, r, p]), 9));
    }
}
