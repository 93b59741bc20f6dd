//! A coverage's output features: each polygon feature rebuilt from its fitted arcs (each ring its
//! arcs' coordinates in ring order, cut at ±180 where it crosses, small rings kept or dropped) with
//! its `properties.fit`.

use crate::earth::coverage::arcs::{ArcGraph, ArcUse};
use crate::earth::coverage::read::CoverageInput;
use crate::earth::coverage::{FeatureRings, FittedArc, PolygonArcs};
use crate::earth::curve::output::{compression_ratio, round_up_m};
use crate::earth::job::{Job, OutputFormat};
use crate::earth::lonlat::{rad_to_m, round_to};
use crate::earth::polygon::{antimeridian, area, small_rings};

use serde_json::{json, Map, Value};

/// What rebuilding a feature reads: the results of the earlier steps.
pub(super) struct Rebuild<'a> {
    pub(super) job: &'a Job,
    pub(super) input: &'a CoverageInput,
    pub(super) graph: &'a ArcGraph,
    pub(super) arcs: &'a [FittedArc],
    /// The job's tolerance, radians and metres.
    pub(super) tol_rad: f64,
    pub(super) tolerance_m: f64,
}

/// A feature's polygons rebuilt from arcs.
struct Polygons {
    /// Output polygons (JSON) and the same as `[lon, lat]`.
    out_polys: Vec<Value>,
    out_ll: Vec<Vec<Vec<[f64; 2]>>>,
    /// Some polygon crossed ±180 and was cut.
    split_any: bool,
    /// The arcs used (sorted, once each).
    arcs_used: Vec<usize>,
    /// `properties.fit.parts`.
    parts: Vec<Value>,
    /// The polygons as rings of arc uses (for TopoJSON).
    ring_uses_out: PolygonArcs,
    /// Pointers of the rings kept small and of those dropped.
    kept: Vec<String>,
    /// Some ring kept small is written apart from the arcs (not kept as an arc).
    kept_apart: bool,
    dropped: Vec<String>,
    /// The largest two-way distance between a kept ring and its input (radians).
    kept_two_way_rad: f64,
}

/// One polygon feature rebuilt, and its numbers for the dataset report.
pub(super) struct RebuiltFeature {
    /// The output Feature.
    pub(super) feature: Value,
    /// Its polygons as rings of arc uses, when every ring is made of arcs (none cut at ±180,
    /// kept small or dropped).
    pub(super) rings: Option<PolygonArcs>,
    pub(super) two_way_rad: f64,
    pub(super) max_error_rad: f64,
    pub(super) tolerance_met: bool,
    pub(super) area_change: f64,
    pub(super) stored_numbers: usize,
    pub(super) input_points: usize,
    pub(super) output_points: usize,
    /// Rings read (curves, in the counters).
    pub(super) curves: usize,
    pub(super) kept: Vec<String>,
    pub(super) dropped: Vec<String>,
}

impl Rebuild<'_> {
    /// Rebuilds feature `fi` (a `kind`, `Polygon` or `MultiPolygon`) from its rings' arcs.
    pub(super) fn feature(
        &self,
        fi: usize,
        kind: &str,
        feature: &Value,
        polys: &FeatureRings<'_>,
    ) -> RebuiltFeature {
        let (graph, fitted, input_ll) = (self.graph, self.arcs, &self.input.input_ll);
        let (job, tol_rad, tolerance_m) = (self.job, self.tol_rad, self.tolerance_m);
        let mut p = self.polygons(fi, kind, polys);
        let feature_arcs: Vec<&FittedArc> = p.arcs_used.iter().map(|&a| &fitted[a]).collect();
        let met = feature_arcs.iter().all(|a| a.tolerance_met);
        // Rings kept small are part of what is written: their distance is in the bound.
        let tw = feature_arcs
            .iter()
            .map(|a| a.two_way_rad)
            .fold(p.kept_two_way_rad, f64::max);
        let err = feature_arcs
            .iter()
            .map(|a| a.max_error_rad)
            .fold(p.kept_two_way_rad, f64::max);
        let met = met && rad_to_m(p.kept_two_way_rad) <= tolerance_m;
        let stored: usize = feature_arcs.iter().map(|a| a.stored_numbers).sum();
        let n_in: usize = input_ll[fi].iter().flatten().map(Vec::len).sum();
        let n_out: usize = p.out_ll.iter().flatten().map(Vec::len).sum();
        let area_in = area::lonlat_polygons_area_m2(&input_ll[fi]);
        let area_out = area::lonlat_polygons_area_m2(&p.out_ll);
        let area_change = area::area_change(area_in, area_out);
        let shared = p
            .arcs_used
            .iter()
            .filter(|&&a| graph.arcs[a].uses > 1)
            .count();
        let geometry = if p.out_polys.is_empty() && !p.dropped.is_empty() {
            // Every polygon dropped: the feature stays, its geometry empty.
            json!({"type": "MultiPolygon", "coordinates": []})
        } else if p.out_polys.is_empty() {
            Value::Null
        } else if kind == "Polygon" && p.out_polys.len() == 1 {
            json!({"type": "Polygon", "coordinates": p.out_polys.pop().expect("one polygon")})
        } else {
            json!({"type": "MultiPolygon", "coordinates": p.out_polys})
        };
        // Foreign members of the input geometry come back with it (RFC 7946 §6.1).
        let mut geometry = geometry;
        if let (Some(g), Some(input)) = (
            geometry.as_object_mut(),
            feature.get("geometry").and_then(Value::as_object),
        ) {
            for (k, v) in input {
                if !matches!(k.as_str(), "type" | "coordinates" | "bbox") {
                    g.insert(k.clone(), v.clone());
                }
            }
        }
        let mut info = Map::new();
        info.insert("topology".into(), json!("shared"));
        info.insert("tolerance_m".into(), json!(tolerance_m));
        info.insert("tolerance_met".into(), json!(met));
        info.insert("max_error_m".into(), json!(round_to(rad_to_m(err), 3)));
        info.insert("two_way_distance_m".into(), json!(round_up_m(rad_to_m(tw))));
        info.insert("input_points".into(), json!(n_in));
        info.insert("output_points".into(), json!(n_out));
        info.insert("arcs".into(), json!(p.arcs_used.len()));
        info.insert("shared_arcs".into(), json!(shared));
        info.insert("stored_numbers".into(), json!(stored));
        info.insert(
            "compression_ratio".into(),
            json!(compression_ratio(n_in, stored)),
        );
        info.insert("area_m2".into(), json!(round_to(area_out, 0)));
        info.insert("area_change".into(), json!(round_to(area_change, 9)));
        info.insert("antimeridian_split".into(), json!(p.split_any));
        info.insert("kept_rings".into(), json!(p.kept));
        if job.drop_small_rings {
            info.insert("dropped_rings".into(), json!(p.dropped));
        }
        info.insert(
            "tightened_arcs".into(),
            json!(feature_arcs
                .iter()
                .filter(|a| a.tolerance_rad < tol_rad)
                .count()),
        );
        info.insert("geometry".into(), json!(kind));
        info.insert("parts".into(), Value::Array(p.parts));
        // The feature's members but its geometry (replaced) and box (no longer its own).
        let mut out: Map<String, Value> = feature
            .as_object()
            .into_iter()
            .flatten()
            .filter(|(k, _)| !matches!(k.as_str(), "geometry" | "bbox"))
            .map(|(k, v)| (k.clone(), v.clone()))
            .collect();
        out.insert("geometry".into(), geometry);
        let mut props = match out.remove("properties") {
            Some(Value::Object(p)) => p,
            _ => Map::new(),
        };
        props.insert("fit".into(), Value::Object(info));
        out.insert("properties".into(), Value::Object(props));
        RebuiltFeature {
            feature: Value::Object(out),
            rings: (!p.split_any && !p.kept_apart && p.dropped.is_empty())
                .then_some(p.ring_uses_out),
            two_way_rad: tw,
            max_error_rad: err,
            tolerance_met: met,
            area_change,
            stored_numbers: stored,
            input_points: n_in,
            output_points: n_out,
            curves: polys.iter().map(Vec::len).sum::<usize>(),
            kept: p.kept,
            dropped: p.dropped,
        }
    }

    /// The polygons of feature `fi` from its rings' arcs.
    fn polygons(&self, fi: usize, kind: &str, polys: &FeatureRings<'_>) -> Polygons {
        let (job, fitted, tol_rad) = (self.job, self.arcs, self.tol_rad);
        let (sources, rings) = (&self.input.sources, &self.input.rings);
        let polygon_poles = &self.input.polygon_poles;
        let precision = job.output.precision;
        let mut out_polys: Vec<Value> = Vec::new();
        let mut out_ll: Vec<Vec<Vec<[f64; 2]>>> = Vec::new();
        let mut split_any = false;
        let mut arcs_used: Vec<usize> = Vec::new();
        let mut parts = Vec::new();
        let mut ring_uses_out = Vec::new();
        let mut kept: Vec<String> = Vec::new();
        let mut kept_apart = false;
        let mut kept_two_way_rad: f64 = 0.0;
        let mut dropped: Vec<String> = Vec::new();
        for (pi, poly) in polys.iter().enumerate() {
            let fitted_ring = |uses: &[ArcUse]| {
                (!uses.is_empty())
                    .then(|| ring_lonlat(uses, fitted))
                    .filter(|ring| !small_rings::collapsed_lonlat(ring))
            };
            // With drop_small_rings, a polygon whose exterior collapses goes with its holes.
            if job.drop_small_rings && poly.first().is_some_and(|(_, u)| fitted_ring(u).is_none()) {
                dropped.extend(poly.iter().map(|(ri, _)| sources[*ri].pointer.clone()));
                continue;
            }
            // A ring with no arcs (under 3 distinct vertices) or whose fitted outline bounds no
            // area is kept as a triangle of its own vertices or as it came (small_rings), as
            // per-feature fitting keeps it: a TopoJSON output then writes this feature's
            // rings as arcs of their own.
            let mut ll_rings: Vec<Vec<[f64; 2]>> = Vec::with_capacity(poly.len());
            let mut uses_out = Vec::with_capacity(poly.len());
            for (r, (ri, uses)) in poly.iter().enumerate() {
                let fitted_ring = fitted_ring(uses);
                let path = if kind == "Polygon" {
                    vec![r]
                } else {
                    vec![pi, r]
                };
                match fitted_ring {
                    None if job.drop_small_rings => {
                        dropped.push(sources[*ri].pointer.clone());
                        continue;
                    }
                    Some(ring) => {
                        let mut part = json!({
                            "path": path,
                            "arcs": uses.iter().map(ArcUse::topojson_index).collect::<Vec<_>>(),
                        });
                        // A whole ring kept small as an arc (fit_arc::keep_arc).
                        if let [u] = &uses[..] {
                            if let Some(how) = fitted[u.arc].small_ring {
                                part["small_ring"] = json!(how.name());
                                kept.push(sources[*ri].pointer.clone());
                            }
                        }
                        parts.push(part);
                        arcs_used.extend(uses.iter().map(|u| u.arc));
                        ll_rings.push(ring);
                    }
                    None => {
                        // On TopoJSON's grid a position moves by up to half a cell's
                        // diagonal: the kept positions are chosen within the tolerance less
                        // that.
                        let topo = job.format == OutputFormat::TopoJson;
                        let grid_rad = if topo {
                            job.output.rounding_bound_rad()
                        } else {
                            0.0
                        };
                        let (ring, how) =
                            // At the default precision at least: a kept ring can be smaller
                            // than the grid a tolerance chose.
                            small_rings::kept_lonlat(
                                &rings[*ri].points,
                                Some((tol_rad - grid_rad).max(0.5 * tol_rad)),
                                precision.max(crate::earth::DEFAULT_PRECISION),
                            );
                        // TopoJSON writes it on its grid (10^-precision), GeoJSON as kept.
                        let written: Vec<[f64; 2]> = if topo {
                            ring.iter()
                                .map(|p| [job.output.round_deg(p[0]), job.output.round_deg(p[1])])
                                .collect()
                        } else {
                            ring.clone()
                        };
                        kept_two_way_rad = kept_two_way_rad
                            .max(small_rings::kept_two_way_rad(&rings[*ri].points, &written));
                        parts.push(json!({"path": path, "arcs": [], "small_ring": how.name()}));
                        kept.push(sources[*ri].pointer.clone());
                        kept_apart = true;
                        ll_rings.push(ring);
                    }
                }
                uses_out.push(uses.to_vec());
            }
            if ll_rings.iter().all(|r| is_plain(r)) {
                out_polys.push(json!(ll_rings));
                out_ll.push(ll_rings);
                // An arc that rounds to one position (two junctions closer than the
                // precision) adds nothing to the ring but a zero-length edge in readers that
                // join arcs; the ring's TopoJSON leaves it out.
                let degenerate = |u: &ArcUse| {
                    let d = &fitted[u.arc].dense_ll;
                    d.iter().all(|p| *p == d[0])
                };
                ring_uses_out.push(
                    uses_out
                        .into_iter()
                        .map(|uses: Vec<ArcUse>| {
                            let kept: Vec<ArcUse> =
                                uses.iter().filter(|u| !degenerate(u)).copied().collect();
                            if kept.is_empty() {
                                uses
                            } else {
                                kept
                            }
                        })
                        .collect::<Vec<_>>(),
                );
            } else {
                split_any = true;
                let rings3: Vec<Vec<[f64; 3]>> = ll_rings
                    .iter()
                    .map(|r| r.iter().map(|p| [p[0], p[1], 0.0]).collect())
                    .collect();
                let pole = polygon_poles[fi].get(pi).copied().flatten();
                let split =
                    antimeridian::split_polygon_around(&rings3, &|x| job.output.round_deg(x), pole);
                for rings_ll in split {
                    let rings_ll: Vec<Vec<[f64; 2]>> = rings_ll
                        .iter()
                        .map(|r| {
                            r.iter()
                                .map(|p| [p[0], job.output.round_deg(p[1])])
                                .collect()
                        })
                        .collect();
                    out_polys.push(json!(rings_ll));
                    out_ll.push(rings_ll);
                }
            }
        }
        arcs_used.sort_unstable();
        arcs_used.dedup();
        Polygons {
            out_polys,
            out_ll,
            split_any,
            arcs_used,
            parts,
            ring_uses_out,
            kept,
            kept_apart,
            dropped,
            kept_two_way_rad,
        }
    }
}

/// A ring's output coordinates from its arcs: each arc's rounded dense coordinates in ring
/// order (reversed where used reversed), the junction shared by consecutive arcs once, the
/// first position repeated at the end. Coordinates at exactly ±180 degrees take the sign of
/// the ring around them.
pub(super) fn ring_lonlat(uses: &[ArcUse], arcs: &[FittedArc]) -> Vec<[f64; 2]> {
    let mut out: Vec<[f64; 2]> = Vec::new();
    for u in uses {
        let d = &arcs[u.arc].dense_ll;
        let mut push = |p: &[f64; 2]| {
            if out.last() != Some(p) {
                out.push(*p);
            }
        };
        if u.reversed {
            d.iter().rev().for_each(&mut push);
        } else {
            d.iter().for_each(&mut push);
        }
    }
    if out.len() > 1 && out.first() == out.last() {
        out.pop();
    }
    // ±180: the sign of the nearest longitude before it that is not ±180.
    let n = out.len();
    if let Some(anchor) = (0..n).find(|&i| out[i][0].abs() != 180.0) {
        let mut side = out[anchor][0].signum();
        for k in 1..=n {
            let i = (anchor + k) % n;
            if out[i][0].abs() == 180.0 {
                out[i][0] = 180.0 * side;
            } else {
                side = out[i][0].signum();
            }
        }
    }
    if let Some(&first) = out.first() {
        out.push(first);
    }
    out
}

/// No step of the ring spans more than 180 degrees of longitude: it does not cross the
/// antimeridian and needs no splitting.
pub(super) fn is_plain(ring: &[[f64; 2]]) -> bool {
    ring.windows(2).all(|w| (w[1][0] - w[0][0]).abs() <= 180.0)
}
