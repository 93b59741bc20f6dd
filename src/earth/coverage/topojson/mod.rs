//! TopoJSON output of a coverage fitted with shared topology ([`crate::earth::coverage`]).
//!
//! **Quantised, delta-encoded arcs.** The topology's `arcs` are the dense fitted arcs, written
//! as TopoJSON's quantised integers: `transform` is `{"scale": [s, s], "translate":
//! [-180, -90]}` with `s = m·10^-p`, `p` the output `precision` (which a tolerance chooses,
//! [`crate::earth::precision_for_tolerance`]) and `m` the coverage's grid multiple (1, or with
//! a precision chosen by the tolerance the coarsest step rounding within a third of it,
//! [`crate::earth::job::topojson_grid_multiple`]: 0.004 degrees at 1 km); each arc's first
//! position is `[round((lon + 180)/s), round((lat + 90)/s)]` and every later one the difference
//! from the previous. The grid is the one the fit already rounds its control points and dense
//! positions to, so a reader's positions `k·s − 180` are the rounded positions (within 1e-12
//! degrees, float arithmetic) and the certified two-way distance of the fit, measured on the
//! rounded curve, covers what is written: quantisation adds nothing to it.
//!
//! Arc `i` is arc `i` of the coverage. Polygon features rebuilt from arcs reference them (`~i`
//! for an arc used reversed); anything else (lines, polygons split at the antimeridian) gets
//! arcs of its own after those. Every geometry carries the feature's `properties` (with
//! `properties.fit`) and `id`; they sit in one GeometryCollection object named `collection`.
//!
//! **Splines, compact.** The foreign member `spherefit` holds the dataset report (the GeoJSON
//! output's `topology` member without its `arcs`) and, unless the features carry only their
//! geometry ([`Carry::Geometry`]), `splines`: for arc `i`, `null` when the arc as written *is*
//! its spline (degree 1, uniform knots, control points = the arc's positions: stored once), or
//! `{"degree", "control_points", "knots"?}` with the control points quantised and
//! delta-encoded as the arcs are (same `transform`) and `knots` only when stored (not the
//! clamped uniform ones). A degree-1 arc's spline is the great-circle polyline through its
//! positions, which is what a TopoJSON reader draws.

mod rings;

use crate::earth::coverage::topojson::rings::{ArcIndex, Cell, Piece};
use crate::earth::coverage::Coverage;
use crate::earth::job::Carry;
use rayon::prelude::*;
use serde_json::{json, Map, Value};

/// The name of the one object of the topology.
pub const OBJECT_NAME: &str = "collection";

/// The quantisation of a topology: a grid of `multiple` steps of `precision` decimals of a
/// degree.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Quantisation {
    /// Grid steps per degree: `10^precision / multiple`.
    pub steps_per_degree: f64,
    /// The grid step, degrees (the transform's scale).
    pub step_deg: f64,
}

impl Quantisation {
    /// The grid of `precision` decimals.
    pub fn new(precision: u32) -> Quantisation {
        Quantisation::of_grid(precision, 1)
    }

    /// The grid of `multiple` steps of `precision` decimals
    /// ([`crate::earth::OutputOptions::grid_multiple`]).
    pub fn of_grid(precision: u32, multiple: u32) -> Quantisation {
        Quantisation {
            steps_per_degree: 10f64.powi(precision as i32) / f64::from(multiple.max(1)),
            step_deg: f64::from(multiple.max(1)) / 10f64.powi(precision as i32),
        }
    }

    /// The TopoJSON `transform` member.
    pub fn transform(&self) -> Value {
        let step = self.step_deg;
        json!({"scale": [step, step], "translate": [-180.0, -90.0]})
    }

    /// The grid index of a longitude and of a latitude.
    fn index(&self, lon: f64, lat: f64) -> Cell {
        [
            ((lon + 180.0) * self.steps_per_degree).round() as i64,
            ((lat + 90.0) * self.steps_per_degree).round() as i64,
        ]
    }

    /// Positions `[lon, lat, extra...]` as a quantised, delta-encoded TopoJSON arc; values
    /// after the first two (altitudes) are written as they are.
    pub fn arc(&self, positions: &[Vec<f64>]) -> Value {
        let mut prev = [0i64; 2];
        let mut out = Vec::with_capacity(positions.len());
        for (j, p) in positions.iter().enumerate() {
            let k = self.index(p[0], p[1]);
            let d = if j == 0 {
                k
            } else {
                [k[0] - prev[0], k[1] - prev[1]]
            };
            prev = k;
            let mut row: Vec<Value> = vec![json!(d[0]), json!(d[1])];
            row.extend(p[2..].iter().map(|&x| json!(x)));
            out.push(Value::Array(row));
        }
        Value::Array(out)
    }

    /// A GeoJSON position array (`[[lon, lat, ...], ...]`) as a quantised arc.
    fn arc_of_json(&self, line: &Value) -> Value {
        self.arc(&positions(line))
    }

    /// Grid positions as a delta-encoded TopoJSON arc.
    fn arc_of_cells(&self, cells: &[Cell]) -> Value {
        let mut prev: Option<Cell> = None;
        let out: Vec<Value> = cells
            .iter()
            .map(|k| {
                let d = prev.map_or(*k, |p| [k[0] - p[0], k[1] - p[1]]);
                prev = Some(*k);
                json!(d)
            })
            .collect();
        Value::Array(out)
    }
}

/// The compact spline of arc `a` (see the module docs): `None` when the arc as written is its
/// spline.
fn compact_spline(a: &crate::earth::coverage::FittedArc, q: &Quantisation) -> Option<Value> {
    let uniform = a.spline.has_clamped_uniform_knots();
    if a.spline.degree() == 1 && uniform && a.control_ll == a.dense_ll {
        return None;
    }
    let ctrl: Vec<Vec<f64>> = a.control_ll.iter().map(|p| p.to_vec()).collect();
    let mut m = Map::new();
    m.insert("degree".into(), json!(a.spline.degree()));
    m.insert("control_points".into(), q.arc(&ctrl));
    if !uniform {
        m.insert("knots".into(), json!(a.spline.knots()));
    }
    Some(Value::Object(m))
}

/// The TopoJSON topology of a fitted coverage, quantised at `precision` decimals (times its
/// grid multiple, [`Coverage::grid_multiple`]), with the
/// compact splines unless `carry` is [`Carry::Geometry`].
pub fn to_topology(mut c: Coverage, precision: u32, carry: Carry) -> Value {
    let q = Quantisation::of_grid(precision, c.grid_multiple);
    let cells: Vec<Vec<Cell>> = c
        .arcs
        .par_iter()
        .map(|a| a.dense_ll.iter().map(|p| q.index(p[0], p[1])).collect())
        .collect();
    let index = ArcIndex::new(&cells);
    // Arcs of their own, after the coverage's (index `coverage + i`): each feature's made on
    // its own (in parallel), numbered from `coverage`, then renumbered after the earlier ones.
    let coverage = c.arcs.len();
    let converted: Vec<(Value, Vec<Value>)> = c
        .features
        .par_iter()
        .zip(&c.feature_rings)
        .map(|(f, rings)| {
            let mut own: Vec<Value> = Vec::new();
            let g = geometry_of(f, rings.as_ref(), &q, &index, coverage, &mut own);
            (g, own)
        })
        .collect();
    let mut own: Vec<Value> = Vec::new();
    let mut geometries = Vec::with_capacity(converted.len());
    for (mut g, mine) in converted {
        if !mine.is_empty() && !own.is_empty() {
            shift_own_indices(&mut g, coverage as i64, own.len() as i64);
        }
        own.extend(mine);
        geometries.push(g);
    }
    // The features are no longer needed: freed on every thread.
    std::mem::take(&mut c.features)
        .into_par_iter()
        .for_each(drop);
    // Coverage arcs no geometry uses (their rings were written with pieces of their own) are
    // left out, and the indices renumbered.
    let mut used = vec![false; coverage];
    for g in &geometries {
        visit_indices(g, &mut |k| {
            let k = if k < 0 { !k } else { k } as usize;
            if k < coverage {
                used[k] = true;
            }
        });
    }
    let mut renumber: Vec<i64> = Vec::with_capacity(coverage + own.len());
    let mut next = 0i64;
    for &u in &used {
        renumber.push(next);
        next += i64::from(u);
    }
    renumber.extend((0..own.len() as i64).map(|i| next + i));
    for g in &mut geometries {
        remap_indices(g, &renumber);
    }
    let mut arcs: Vec<Value> = cells
        .par_iter()
        .zip(&used)
        .filter(|(_, &u)| u)
        .map(|(a, _)| q.arc_of_cells(a))
        .collect();
    arcs.extend(own);
    let mut report = std::mem::take(&mut c.report);
    if carry != Carry::Geometry {
        report["splines"] = Value::Array(
            c.arcs
                .par_iter()
                .zip(&used)
                .filter(|(_, &u)| u)
                .map(|(a, _)| compact_spline(a, &q).unwrap_or(Value::Null))
                .collect(),
        );
    }
    let mut out = Map::new();
    out.insert("type".into(), json!("Topology"));
    out.insert("transform".into(), q.transform());
    out.insert(
        "objects".into(),
        json!({ OBJECT_NAME: {"type": "GeometryCollection", "geometries": geometries} }),
    );
    out.insert("arcs".into(), Value::Array(arcs));
    out.insert("spherefit".into(), report);
    // What is left of the coverage (its arcs' curves and dense points, the graph) is freed
    // on the pool, off the caller's path: freed here it was a fifth of writing the output of
    // the 10m countries, on one thread (docs/speed.md, "tenth session").
    rayon::spawn(move || drop(c));
    Value::Object(out)
}

/// Feature `f`'s TopoJSON geometry, with its `id` and `properties`: the arc uses of its
/// `rings` when it was rebuilt from the coverage's arcs, else its geometry converted with arcs
/// of its own pushed to `own` (numbered from `first`).
fn geometry_of(
    f: &Value,
    rings: Option<&crate::earth::coverage::PolygonArcs>,
    q: &Quantisation,
    index: &ArcIndex<'_>,
    first: usize,
    own: &mut Vec<Value>,
) -> Value {
    let geometry = &f["geometry"];
    let mut g = match rings {
        Some(polys) => {
            let refs: Vec<Vec<Vec<i64>>> = polys
                .iter()
                .map(|p| {
                    p.iter()
                        .map(|r| r.iter().map(|u| u.topojson_index()).collect())
                        .collect()
                })
                .collect();
            if geometry["type"] == "Polygon" {
                json!({"type": "Polygon", "arcs": refs[0]})
            } else {
                json!({"type": "MultiPolygon", "arcs": refs})
            }
        }
        None => {
            let mut writer = ArcWriter {
                q,
                index,
                first,
                own,
            };
            convert(geometry, &mut writer)
        }
    };
    if let Some(obj) = g.as_object_mut() {
        if let Some(id) = f.get("id") {
            obj.insert("id".into(), id.clone());
        }
        if let Some(p) = f.get("properties").filter(|p| !p.is_null()) {
            obj.insert("properties".into(), p.clone());
        }
    }
    g
}

/// Adds `by` to the indices of arcs of their own (from `first` on) in a TopoJSON geometry.
fn shift_own_indices(g: &mut Value, first: i64, by: i64) {
    fn walk(v: &mut Value, first: i64, by: i64) {
        match v {
            Value::Array(a) => a.iter_mut().for_each(|x| walk(x, first, by)),
            Value::Number(n) => {
                if let Some(k) = n.as_i64().filter(|&k| k >= first) {
                    *v = json!(k + by);
                }
            }
            _ => {}
        }
    }
    if let Some(arcs) = g.get_mut("arcs") {
        walk(arcs, first, by);
    }
    if let Some(Value::Array(gs)) = g.get_mut("geometries") {
        gs.iter_mut().for_each(|x| shift_own_indices(x, first, by));
    }
}

/// How [`convert`] makes arcs: a line is an arc of its own; a ring runs along the
/// coverage's arcs where it can ([`ArcIndex::pieces`]), with arcs of its own between.
struct ArcWriter<'a> {
    q: &'a Quantisation,
    index: &'a ArcIndex<'a>,
    /// The index of the first arc of their own (after the coverage's).
    first: usize,
    own: &'a mut Vec<Value>,
}

impl ArcWriter<'_> {
    fn push(&mut self, arc: Value) -> i64 {
        self.own.push(arc);
        (self.first + self.own.len() - 1) as i64
    }

    /// A line's one arc.
    fn line(&mut self, line: &Value) -> i64 {
        let arc = self.q.arc_of_json(line);
        self.push(arc)
    }

    /// A ring's arc indices.
    fn ring(&mut self, ring: &Value) -> Vec<i64> {
        let cells: Vec<Cell> = positions(ring)
            .iter()
            .map(|p| self.q.index(p[0], p[1]))
            .collect();
        self.index
            .pieces(&cells)
            .into_iter()
            .map(|piece| match piece {
                Piece::Arc(k) => k,
                Piece::Own(ps) => {
                    let arc = self.q.arc_of_cells(&ps);
                    self.push(arc)
                }
            })
            .collect()
    }
}

/// The `[lon, lat, ...]` positions of a GeoJSON position array (others skipped).
fn positions(line: &Value) -> Vec<Vec<f64>> {
    line.as_array()
        .map(|a| {
            a.iter()
                .filter_map(|p| {
                    let v: Vec<f64> = p.as_array()?.iter().filter_map(Value::as_f64).collect();
                    (v.len() >= 2).then_some(v)
                })
                .collect()
        })
        .unwrap_or_default()
}

/// Calls `f` on every arc index of a TopoJSON geometry (its `arcs`, and those of a
/// collection's geometries).
fn visit_indices(g: &Value, f: &mut dyn FnMut(i64)) {
    fn walk(v: &Value, f: &mut dyn FnMut(i64)) {
        match v {
            Value::Array(a) => a.iter().for_each(|x| walk(x, f)),
            Value::Number(n) => {
                if let Some(k) = n.as_i64() {
                    f(k);
                }
            }
            _ => {}
        }
    }
    if let Some(arcs) = g.get("arcs") {
        walk(arcs, f);
    }
    if let Some(Value::Array(gs)) = g.get("geometries") {
        gs.iter().for_each(|x| visit_indices(x, f));
    }
}

/// Renumbers the arc indices of a TopoJSON geometry: arc `k` becomes `renumber[k]` (`~k`,
/// an arc used backwards, `~renumber[k]`).
fn remap_indices(g: &mut Value, renumber: &[i64]) {
    fn walk(v: &mut Value, renumber: &[i64]) {
        match v {
            Value::Array(a) => a.iter_mut().for_each(|x| walk(x, renumber)),
            Value::Number(n) => {
                if let Some(k) = n.as_i64() {
                    let m = if k < 0 {
                        !renumber[!k as usize]
                    } else {
                        renumber[k as usize]
                    };
                    *v = json!(m);
                }
            }
            _ => {}
        }
    }
    if let Some(arcs) = g.get_mut("arcs") {
        walk(arcs, renumber);
    }
    if let Some(Value::Array(gs)) = g.get_mut("geometries") {
        gs.iter_mut().for_each(|x| remap_indices(x, renumber));
    }
}

/// A GeoJSON geometry as a TopoJSON one: each line an arc of its own, each ring the arcs
/// `writer` finds for it.
fn convert(g: &Value, writer: &mut ArcWriter<'_>) -> Value {
    let kind = g.get("type").and_then(Value::as_str).unwrap_or("");
    let c = &g["coordinates"];
    fn list(v: &Value) -> &[Value] {
        v.as_array().map_or(&[], Vec::as_slice)
    }
    match kind {
        "Point" | "MultiPoint" => json!({"type": kind, "coordinates": c}),
        // A LineString's `arcs` is one list of arc indices; a MultiLineString's and a Polygon's
        // one such list per line or ring; a MultiPolygon's one per ring of each polygon.
        "LineString" => json!({"type": kind, "arcs": [writer.line(c)]}),
        "MultiLineString" => {
            let refs: Vec<[i64; 1]> = list(c).iter().map(|r| [writer.line(r)]).collect();
            json!({"type": kind, "arcs": refs})
        }
        "Polygon" => {
            let refs: Vec<Vec<i64>> = list(c).iter().map(|r| writer.ring(r)).collect();
            json!({"type": kind, "arcs": refs})
        }
        "MultiPolygon" => {
            let refs: Vec<Vec<Vec<i64>>> = list(c)
                .iter()
                .map(|p| list(p).iter().map(|r| writer.ring(r)).collect())
                .collect();
            json!({"type": kind, "arcs": refs})
        }
        "GeometryCollection" => {
            let gs: Vec<Value> = list(&g["geometries"])
                .iter()
                .map(|x| convert(x, writer))
                .collect();
            json!({"type": kind, "geometries": gs})
        }
        _ => json!({"type": null}),
    }
}

/// The topology serialised with `"type": "Topology"` first (readers such as GDAL recognise a
/// TopoJSON file by its first bytes), then `transform`, `objects`, `arcs` and the other
/// members.
pub fn to_bytes(topology: &Value) -> Vec<u8> {
    let mut out = b"{\"type\":\"Topology\"".to_vec();
    let Some(map) = topology.as_object() else {
        return serde_json::to_vec(topology).expect("JSON values serialise");
    };
    let mut keys: Vec<&String> = map.keys().filter(|k| *k != "type").collect();
    let rank = |k: &str| match k {
        "transform" => 0,
        "objects" => 1,
        "arcs" => 2,
        _ => 3,
    };
    keys.sort_by_key(|k| rank(k));
    for k in keys {
        out.push(b',');
        out.extend(serde_json::to_vec(k).expect("a string serialises"));
        out.push(b':');
        match &map[k] {
            // The arcs (and any other array): items written in parallel, joined as
            // serde_json joins them.
            Value::Array(items) => {
                let parts: Vec<Vec<u8>> = items
                    .par_iter()
                    .map(|v| serde_json::to_vec(v).expect("JSON values serialise"))
                    .collect();
                out.push(b'[');
                for (i, p) in parts.iter().enumerate() {
                    if i > 0 {
                        out.push(b',');
                    }
                    out.extend_from_slice(p);
                }
                out.push(b']');
            }
            v => out.extend(serde_json::to_vec(v).expect("JSON values serialise")),
        }
    }
    out.push(b'}');
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// How many array levels sit above the arc indices (0 for an index itself).
    fn depth(v: &Value) -> usize {
        match v {
            Value::Array(a) => 1 + a.iter().map(depth).max().unwrap_or(0),
            _ => 0,
        }
    }

    #[test]
    fn geometries_with_arcs_of_their_own_nest_their_indices_as_topojson_says() {
        let line = json!([[0, 0], [1, 1]]);
        let ring = json!([[0, 0], [1, 0], [1, 1], [0, 0]]);
        // No coverage arcs: every line and ring is an arc of its own.
        let q = Quantisation::new(0);
        let none: Vec<Vec<Cell>> = Vec::new();
        let index = ArcIndex::new(&none);
        let mut arcs = Vec::new();
        let mut writer = ArcWriter {
            q: &q,
            index: &index,
            first: 0,
            own: &mut arcs,
        };
        for (g, levels) in [
            (json!({"type": "LineString", "coordinates": line}), 1),
            (
                json!({"type": "MultiLineString", "coordinates": [line, line]}),
                2,
            ),
            (json!({"type": "Polygon", "coordinates": [ring]}), 2),
            (
                json!({"type": "MultiPolygon", "coordinates": [[ring], [ring, ring]]}),
                3,
            ),
        ] {
            let t = convert(&g, &mut writer);
            assert_eq!(depth(&t["arcs"]), levels, "{g} -> {t}");
        }
        let t = convert(
            &json!({"type": "MultiPolygon", "coordinates": [[ring], [ring, ring]]}),
            &mut writer,
        );
        // 7 arcs before: 1 + 2 (lines) + 1 + 3 (rings).
        assert_eq!(t["arcs"], json!([[[7]], [[8], [9]]]));
        assert_eq!(arcs.len(), 10);
    }

    #[test]
    fn arcs_of_their_own_made_per_feature_in_parallel_are_numbered_in_feature_order() {
        // Two squares sharing a side, and lines between and after them: each line is an arc
        // of its own, numbered after the coverage's arcs in feature order, whatever thread
        // wrote it.
        let square = |x: f64| json!([[[x, 0], [x + 1.0, 0], [x + 1.0, 1], [x, 1], [x, 0]]]);
        let line = |y: f64| json!({"type": "Feature", "properties": {"y": y}, "geometry": {"type": "LineString", "coordinates": [[0, y], [1, y + 0.5], [2, y]]}});
        let doc = json!({"type": "FeatureCollection", "features": [
            line(3.0),
            {"type": "Feature", "properties": {}, "geometry": {"type": "Polygon", "coordinates": square(0.0)}},
            line(5.0),
            line(7.0),
            {"type": "Feature", "properties": {}, "geometry": {"type": "Polygon", "coordinates": square(1.0)}},
            line(9.0),
        ]});
        let job = crate::earth::Job {
            operation: crate::earth::Operation::FitToTolerance {
                options: crate::sphere::FitOptions::faithful(),
                tolerance_m: 100.0,
            },
            ..crate::earth::Job::fit(crate::sphere::FitOptions::default())
        };
        let c = crate::earth::coverage::fit_coverage(
            crate::earth::Document::parse(doc, false).unwrap(),
            &job,
        )
        .unwrap();
        let coverage_arcs = c.arcs.len() as i64;
        let t = to_topology(c, 6, Carry::Both);
        let gs = t["objects"][OBJECT_NAME]["geometries"].as_array().unwrap();
        let lines: Vec<(i64, f64)> = gs
            .iter()
            .filter(|g| g["type"] == "LineString")
            .map(|g| {
                (
                    g["arcs"][0].as_i64().unwrap(),
                    g["properties"]["y"].as_f64().unwrap(),
                )
            })
            .collect();
        assert_eq!(
            lines,
            (0..4)
                .map(|k| (coverage_arcs + k, 3.0 + 2.0 * k as f64))
                .collect::<Vec<_>>()
        );
        // Each line's arc starts at its own first position.
        let arcs = t["arcs"].as_array().unwrap();
        assert_eq!(arcs.len() as i64, coverage_arcs + 4);
        for (k, y) in lines {
            assert_eq!(
                arcs[k as usize][0][1],
                json!(((y + 90.0) * 1e6).round() as i64)
            );
        }
    }

    #[test]
    fn arcs_are_quantised_on_the_decimal_grid_and_delta_encoded() {
        let q = Quantisation::new(4);
        let arc = q.arc(&[
            vec![-179.9999, -89.9999],
            vec![179.9999, 89.9999, 12.5],
            vec![10.1234, -0.0001],
        ]);
        assert_eq!(
            arc,
            json!([[1, 1], [3_599_998, 1_799_998, 12.5], [-1_698_765, -900_000]])
        );
        // Decoding as a TopoJSON reader does gives the decimal positions back.
        let t = q.transform();
        let (s, tr) = (t["scale"][0].as_f64().unwrap(), t["translate"].clone());
        let mut k = [0i64; 2];
        let mut decoded = Vec::new();
        for p in arc.as_array().unwrap() {
            k[0] += p[0].as_i64().unwrap();
            k[1] += p[1].as_i64().unwrap();
            decoded.push([
                k[0] as f64 * s + tr[0].as_f64().unwrap(),
                k[1] as f64 * s + tr[1].as_f64().unwrap(),
            ]);
        }
        for (d, e) in decoded.iter().zip([
            [-179.9999, -89.9999],
            [179.9999, 89.9999],
            [10.1234, -0.0001],
        ]) {
            assert!(
                (d[0] - e[0]).abs() < 1e-12 && (d[1] - e[1]).abs() < 1e-12,
                "{d:?}"
            );
        }
        assert_eq!(t["scale"], json!([0.0001, 0.0001]));
    }
}
