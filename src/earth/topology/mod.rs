//! Polygon coverages fitted without gaps (`topology=shared`): every shared border is fitted
//! once, and every ring is rebuilt from the fitted borders, so neighbours share exactly the same
//! output coordinates along their common boundary.
//!
//! # What happens
//! 1. The rings of every Polygon and MultiPolygon feature of the document are cut into arcs
//!    ([`arcs`]: vertices shared within 0.6 mm, junctions where the neighbours change, arcs met
//!    reversed reused reversed). Other features (lines, points, `null`) are processed one by
//!    one as without `topology=shared`.
//! 2. Each arc is fitted once to the tolerance with
//!    [`crate::sphere::compress::tolerance::fit_to_tolerance`], its end control points pinned to its
//!    junctions ([`crate::sphere::compress::tolerance::ToleranceOptions::pin_ends`]), so every arc that
//!    meets at a junction ends exactly there. An arc that is a whole ring (an island, an
//!    enclave and the hole around it) is fitted as a closed curve: started at its sharpest
//!    corner and closed there exactly; when it turns by less than
//!    [`crate::sphere::fit::adaptive_knots::CORNER_ANGLE_RAD`] there, the seam is made C1
//!    ([`crate::sphere::fit::seam::close_seam`]) when the tolerance still holds (`seam:
//!    "smooth"`), else it stays a corner (`seam: "corner"`).
//! 3. Each arc is sampled densely once and rounded to `precision`; its end points are its
//!    junctions' rounded positions. A ring is its arcs' coordinates in ring order (reversed
//!    where the ring runs the arc backwards), so two neighbours' rings hold bit-identical
//!    coordinates along a shared arc.
//! 4. A polygon whose rings cross the antimeridian is cut there into polygons within
//!    [-180, 180] (`properties.fit.antimeridian_split: true`) without moving any vertex: each
//!    crossing gets a vertex on the fitted arc's great-circle step, and a ring winding around
//!    a pole is closed along the pole (`antimeridian::split_polygon`, as per-feature fitting does). Vertices away from the
//!    antimeridian keep their bits, so the shared borders of such a polygon are still
//!    identical to its neighbours'. Coordinates exactly at ±180 degrees take the sign of the
//!    ring around them (the same point either way).
//!
//! Altitudes are not carried (a shared border has one line for two features); output
//! positions are `[lon, lat]`. The splines of the arcs are listed once, in the collection's
//! foreign member `topology.arcs` (GeoJSON) or in the TopoJSON topology's `spherefit` member.

pub mod arcs;

/// How many times an arc that crosses a neighbouring arc (or itself) is refitted at half its
/// tolerance before the crossing is reported as left (`crossings_left`).
pub const TIGHTEN_ROUNDS: usize = 3;

use super::antimeridian;
use super::area;
use super::curve::{
    compression_ratio, prepare_line, round_spline, round_up_m, rounding_bound_rad, sampling_start,
    sphere_error, tolerance_target_rad,
};
use super::features::{process_feature, Document, FeatureStats, Source};
use super::lonlat::{m_to_rad, rad_to_m, round_to, unit_to_lonlat};
use super::sampling::{sample, AUTO_DEVIATION_FRACTION};
use super::small_rings;
use super::{EarthError, Job, Operation, Problem};
use crate::sphere::certify::two_way::{two_way_distance, TwoWayOptions};
use crate::sphere::compress::tolerance::{
    fit_to_tolerance, stored_numbers, KnotRule, ToleranceOptions,
};
use crate::sphere::fit::adaptive_knots::{turning_angles, CORNER_ANGLE_RAD};
use crate::sphere::fit::metrics::pointwise_errors;
use crate::sphere::fit::seam::close_seam;
use crate::sphere::geometry::crossing::polylines_cross;
use crate::sphere::{PointSet, SphericalBSpline};
use arcs::{ArcGraph, ArcUse, InputRing};
use rayon::prelude::*;
use serde_json::{json, Map, Value};
use std::collections::{BTreeSet, HashSet};

pub use super::job::{OutputFormat, Topology};

/// One fitted arc: its rounded spline, its dense output and how well it fits.
#[derive(Clone, Debug)]
pub struct FittedArc {
    /// The spline as returned (control points rounded to `precision`).
    pub spline: SphericalBSpline,
    /// Its control points as `[lon, lat]`.
    pub control_ll: Vec<[f64; 2]>,
    /// How its knots are known.
    pub knot_rule: KnotRule,
    /// Dense output points (unit vectors), ends at the junctions.
    pub dense: Vec<[f64; 3]>,
    /// Dense output points as rounded `[lon, lat]`; the ends are the junctions' positions.
    pub dense_ll: Vec<[f64; 2]>,
    /// Largest distance of an arc vertex from the curve at its parameter, radians.
    pub max_error_rad: f64,
    /// Certified two-way distance between the curve and the arc's input polyline, radians.
    pub two_way_rad: f64,
    /// Both within the tolerance.
    pub tolerance_met: bool,
    /// Numbers the spline stores.
    pub stored_numbers: usize,
    /// Input vertices of the arc (a closed arc's first one once).
    pub input_points: usize,
    /// For a closed arc: `"smooth"` (C1 seam) or `"corner"`; `None` for an open arc.
    pub seam: Option<&'static str>,
    /// The proven bound of the dense polyline's distance from the curve, radians.
    pub sampling_deviation_rad: f64,
    /// The tolerance this arc was fitted to, radians: the job's, or less where a crossing
    /// with a neighbouring arc made the fit tighten it.
    pub tolerance_rad: f64,
}

/// A fitted coverage: the document's features, in order, with polygon features rebuilt from
/// shared arcs.
#[derive(Clone, Debug)]
pub struct Coverage {
    /// The output features (GeoJSON), in input order.
    pub features: Vec<Value>,
    /// The input collection's foreign members.
    pub members: Map<String, Value>,
    /// The arcs and the rings that use them.
    pub graph: ArcGraph,
    /// The fitted arcs (index = arc index).
    pub arcs: Vec<FittedArc>,
    /// For each feature: its polygons as rings of arc uses, when it was rebuilt from arcs
    /// (not for other features, nor for polygons split at the antimeridian).
    pub feature_rings: Vec<Option<PolygonArcs>>,
    /// The dataset report (also the GeoJSON collection's `topology` member).
    pub report: Value,
    /// Counters over all features, arcs counted once for `stored_numbers`.
    pub stats: FeatureStats,
}

impl Coverage {
    /// The GeoJSON FeatureCollection: the features, the input's foreign members (without a
    /// stale `bbox`), and `topology` with the dataset report and every arc's spline.
    pub fn into_feature_collection(self) -> Value {
        let mut out = Map::new();
        out.insert("type".into(), json!("FeatureCollection"));
        for (k, v) in self.members {
            if k != "bbox" {
                out.insert(k, v);
            }
        }
        let mut report = self.report;
        report["arcs"] = Value::Array(self.arcs.iter().map(arc_json).collect());
        out.insert("topology".into(), report);
        out.insert("features".into(), Value::Array(self.features));
        Value::Object(out)
    }
}

/// An arc's spline and numbers, as listed in the outputs.
pub fn arc_json(a: &FittedArc) -> Value {
    let mut m = Map::new();
    m.insert("closed".into(), json!(a.seam.is_some()));
    if let Some(s) = a.seam {
        m.insert("seam".into(), json!(s));
    }
    m.insert("input_points".into(), json!(a.input_points));
    m.insert("output_points".into(), json!(a.dense_ll.len()));
    m.insert(
        "max_error_m".into(),
        json!(round_to(rad_to_m(a.max_error_rad), 3)),
    );
    m.insert(
        "two_way_distance_m".into(),
        json!(round_up_m(rad_to_m(a.two_way_rad))),
    );
    m.insert("tolerance_met".into(), json!(a.tolerance_met));
    m.insert(
        "fitted_to_m".into(),
        json!(round_to(rad_to_m(a.tolerance_rad), 3)),
    );
    m.insert("stored_numbers".into(), json!(a.stored_numbers));
    m.insert(
        "knot_rule".into(),
        serde_json::to_value(a.knot_rule).expect("enum serialises"),
    );
    m.insert(
        "spline".into(),
        json!({
            "degree": a.spline.degree(),
            "knots": a.spline.knots(),
            "control_points": a.control_ll,
        }),
    );
    Value::Object(m)
}

/// A feature's polygons, each a list of (input ring index, its arc uses).
type FeatureRings<'a> = Vec<Vec<(usize, &'a [ArcUse])>>;

/// A feature's polygons as rings of arc uses.
pub type PolygonArcs = Vec<Vec<Vec<ArcUse>>>;

/// A polygon ring of the input and where it came from.
struct RingSource {
    feature: usize,
    polygon: usize,
    ring: usize,
    pointer: String,
}

/// Fits the polygon features of `doc` as one coverage with shared borders (see the module
/// docs); the job's operation must be [`Operation::FitToTolerance`]. Other features are
/// processed one by one with `job`.
///
/// # Errors
/// The first problem found, with a pointer into the input document: invalid features or
/// positions, a ring with fewer than 3 distinct vertices, an arc that cannot be fitted, output
/// over the limits.
pub fn fit_coverage(doc: Document, job: &Job) -> Result<Coverage, EarthError> {
    let Operation::FitToTolerance {
        options,
        tolerance_m,
    } = &job.operation
    else {
        job.clone()
            .with_topology(Topology::Shared, OutputFormat::GeoJson)
            .validate()?;
        unreachable!("validate refuses other operations with shared topology");
    };
    let _scope = job.cancel.enter();
    // Which slots are polygon features; the others are processed as usual.
    let mut features: Vec<Option<Value>> = vec![None; doc.slots.len()];
    let mut polygon_kind: Vec<Option<&'static str>> = vec![None; doc.slots.len()];
    let mut stats = FeatureStats::default();
    let mut rings: Vec<InputRing> = Vec::new();
    let mut sources: Vec<RingSource> = Vec::new();
    let mut input_ll: Vec<Vec<Vec<Vec<[f64; 2]>>>> = vec![Vec::new(); doc.slots.len()];
    // The pole each rejoined polygon of a feature was closed along in its cut-form input.
    let mut polygon_poles: Vec<Vec<Option<f64>>> = vec![Vec::new(); doc.slots.len()];
    for (fi, slot) in doc.slots.iter().enumerate() {
        job.cancel
            .check()
            .map_err(|e| EarthError::new(slot.pointer.clone(), Problem::Fit(e)))?;
        let kind = match &slot.source {
            Source::Feature { feature, .. } => polygon_type(feature),
            Source::Spline(_) => None,
        };
        let Some(kind) = kind else {
            let out = slot.process(job)?;
            stats.merge(&out.stats);
            features[fi] = Some(out.feature.into_value());
            continue;
        };
        let Source::Feature {
            feature,
            geometry_pointer,
        } = &slot.source
        else {
            unreachable!("polygon_type only accepts features");
        };
        // The feature's own members are checked as without topology, on a copy without its
        // geometry.
        let mut bare = feature.clone();
        bare["geometry"] = Value::Null;
        process_feature(&bare, &slot.pointer, job)?;
        let geometry = &feature["geometry"];
        check_geometry_bbox(geometry, geometry_pointer)?;
        let cptr = format!("{geometry_pointer}/coordinates");
        let coords = geometry
            .get("coordinates")
            .ok_or_else(|| invalid(geometry_pointer, format!("a {kind} needs \"coordinates\"")))?;
        let polygons: Vec<(String, &Value)> = if kind == "Polygon" {
            vec![(cptr.clone(), coords)]
        } else {
            array_of(coords, &cptr, "polygons")?
                .iter()
                .enumerate()
                .map(|(i, p)| (format!("{cptr}/{i}"), p))
                .collect()
        };
        // Polygons cut at ±180 are rejoined into rings on the sphere, as per-feature fitting
        // does (antimeridian::rejoin).
        let rejoined = antimeridian::rejoin::rejoin_cut_polygons(&polygons)
            .transpose()
            .map_err(super::features::no_area_on_the_sphere)?;
        let kind = match &rejoined {
            Some(p) if kind == "Polygon" && p.len() == 1 => "Polygon",
            Some(_) => "MultiPolygon",
            None => kind,
        };
        let mut ring_sets: Vec<Vec<(String, &Value)>> = Vec::with_capacity(polygons.len());
        match &rejoined {
            Some(polys) => {
                for poly in polys {
                    ring_sets.push(poly.rings.iter().map(|(p, r)| (p.clone(), r)).collect());
                }
                polygon_poles[fi] = polys.iter().map(|p| p.pole).collect();
            }
            None => {
                for (pptr, poly) in &polygons {
                    ring_sets.push(
                        array_of(poly, pptr, "rings")?
                            .iter()
                            .enumerate()
                            .map(|(ri, ring)| (format!("{pptr}/{ri}"), ring))
                            .collect(),
                    );
                }
            }
        }
        for (pi, poly_rings) in ring_sets.into_iter().enumerate() {
            let mut poly_ll = Vec::new();
            for (ri, (rptr, ring)) in poly_rings.into_iter().enumerate() {
                // A ring of one distinct position bounds no area: read here, kept as it came below.
                let line = match prepare_line(ring, &rptr, true, None) {
                    Ok((line, _, _)) => line,
                    Err(e) if matches!(e.problem, Problem::TooFewPoints { .. }) => {
                        super::curve::parse_positions(ring, &rptr)?
                    }
                    Err(e) => return Err(e),
                };
                poly_ll.push(
                    line.points
                        .iter()
                        .map(|p| {
                            let (lon, lat) = unit_to_lonlat(p);
                            [lon, lat]
                        })
                        .collect(),
                );
                rings.push(InputRing {
                    points: line.points,
                });
                sources.push(RingSource {
                    feature: fi,
                    polygon: pi,
                    ring: ri,
                    pointer: rptr,
                });
            }
            input_ll[fi].push(poly_ll);
        }
        polygon_kind[fi] = Some(kind);
    }
    let graph = ArcGraph::build(&rings);
    // The first ring using each arc, for error pointers.
    let mut arc_ring = vec![usize::MAX; graph.arcs.len()];
    for (ri, uses) in graph.rings.iter().enumerate() {
        for u in uses {
            if arc_ring[u.arc] == usize::MAX {
                arc_ring[u.arc] = ri;
            }
        }
    }
    let tol_rad = m_to_rad(*tolerance_m);
    let degree_cap = options.degree.max(1);
    let parameterization = options.parameterization;
    let fitted: Vec<FittedArc> = (0..graph.arcs.len())
        .into_par_iter()
        .map(|a| {
            let _scope = job.cancel.enter();
            let pointer = &sources[arc_ring[a]].pointer;
            job.cancel
                .check()
                .map_err(|e| EarthError::new(pointer.clone(), Problem::Fit(e)))?;
            fit_arc(
                &graph.arc_points(a),
                graph.arcs[a].closed,
                tol_rad,
                degree_cap,
                parameterization,
                job,
            )
            .map_err(|e| EarthError::new(pointer.clone(), e.problem))
        })
        .collect::<Vec<_>>()
        .into_iter()
        .collect::<Result<_, _>>()?;
    // Validity: arcs of one polygon (exterior and holes), or meeting at a junction, must not
    // cross each other (nor an arc itself) where the input did not; such arcs are refitted at half the tolerance,
    // up to TIGHTEN_ROUNDS times.
    // Rings by polygon (exterior and holes), so holes are checked against their shell too.
    let mut polygon_rings: std::collections::BTreeMap<(usize, usize), Vec<usize>> =
        Default::default();
    for (ri, src) in sources.iter().enumerate() {
        polygon_rings
            .entry((src.feature, src.polygon))
            .or_default()
            .push(ri);
    }
    let groups: Vec<Vec<usize>> = polygon_rings.into_values().collect();
    let pairs = arc_pairs(&graph, &groups);
    let input_arcs: Vec<Vec<[f64; 3]>> =
        (0..graph.arcs.len()).map(|a| graph.arc_points(a)).collect();
    let input_crossing: HashSet<(usize, usize)> = pairs
        .par_iter()
        .filter(|&&(a, b)| polylines_cross(&input_arcs[a], &input_arcs[b], a == b))
        .copied()
        .collect();
    let mut fitted = fitted;
    let mut arc_tol = vec![tol_rad; graph.arcs.len()];
    let mut crossings_left = Vec::new();
    for round in 0..=TIGHTEN_ROUNDS {
        let crossing: Vec<(usize, usize)> = pairs
            .par_iter()
            .filter(|p| !input_crossing.contains(p))
            .filter(|&&(a, b)| polylines_cross(&fitted[a].dense, &fitted[b].dense, a == b))
            .copied()
            .collect();
        if crossing.is_empty() || round == TIGHTEN_ROUNDS {
            crossings_left = crossing;
            break;
        }
        let mut redo: Vec<usize> = crossing.iter().flat_map(|&(a, b)| [a, b]).collect();
        redo.sort_unstable();
        redo.dedup();
        let refits: Vec<(usize, FittedArc)> = redo
            .par_iter()
            .map(|&a| {
                let _scope = job.cancel.enter();
                let t = 0.5 * arc_tol[a];
                fit_arc(
                    &input_arcs[a],
                    graph.arcs[a].closed,
                    t,
                    degree_cap,
                    parameterization,
                    job,
                )
                .map(|f| (a, f))
                .map_err(|e| EarthError::new(sources[arc_ring[a]].pointer.clone(), e.problem))
            })
            .collect::<Vec<_>>()
            .into_iter()
            .collect::<Result<_, _>>()?;
        for (a, f) in refits {
            arc_tol[a] *= 0.5;
            fitted[a] = FittedArc {
                tolerance_met: f.max_error_rad.max(f.two_way_rad) <= tol_rad,
                ..f
            };
        }
    }
    for (a, f) in fitted.iter_mut().enumerate() {
        f.tolerance_rad = arc_tol[a];
    }
    let tightened = arc_tol.iter().filter(|&&t| t < tol_rad).count();
    // Rebuild the polygon features.
    let mut by_feature: Vec<FeatureRings<'_>> = vec![Vec::new(); doc.slots.len()];
    for (ri, s) in sources.iter().enumerate() {
        let polys = &mut by_feature[s.feature];
        if polys.len() <= s.polygon {
            polys.resize(s.polygon + 1, Vec::new());
        }
        polys[s.polygon].push((ri, graph.rings[ri].as_slice()));
        debug_assert_eq!(polys[s.polygon].len(), s.ring + 1);
    }
    let precision = job.output.precision;
    let mut feature_rings: Vec<Option<PolygonArcs>> = vec![None; doc.slots.len()];
    let mut max_two_way = 0.0f64;
    let mut max_error = 0.0f64;
    let mut all_met = true;
    let mut area_change_max = 0.0f64;
    let mut per_feature_stored = 0usize;
    let mut input_points_total = 0usize;
    let mut output_points_total = 0usize;
    let mut kept_total: Vec<String> = Vec::new();
    let mut dropped_total: Vec<String> = Vec::new();
    for (fi, slot) in doc.slots.iter().enumerate() {
        let Some(kind) = polygon_kind[fi] else {
            continue;
        };
        let Source::Feature { feature, .. } = &slot.source else {
            continue;
        };
        let mut out_polys: Vec<Value> = Vec::new();
        let mut out_ll: Vec<Vec<Vec<[f64; 2]>>> = Vec::new();
        let mut split_any = false;
        let mut arcs_used: Vec<usize> = Vec::new();
        let mut parts = Vec::new();
        let mut ring_uses_out = Vec::new();
        let mut kept: Vec<String> = Vec::new();
        let mut dropped: Vec<String> = Vec::new();
        for (pi, poly) in by_feature[fi].iter().enumerate() {
            let fitted_ring = |uses: &[ArcUse]| {
                (!uses.is_empty())
                    .then(|| ring_lonlat(uses, &fitted))
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
                        parts.push(json!({
                            "path": path,
                            "arcs": uses.iter().map(ArcUse::topojson_index).collect::<Vec<_>>(),
                        }));
                        arcs_used.extend(uses.iter().map(|u| u.arc));
                        ll_rings.push(ring);
                    }
                    None => {
                        let (ring, how) =
                            small_rings::kept_lonlat(&rings[*ri].points, Some(tol_rad), precision);
                        parts.push(json!({"path": path, "arcs": [], "small_ring": how.name()}));
                        kept.push(sources[*ri].pointer.clone());
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
                    antimeridian::split_polygon_around(&rings3, &|x| round_to(x, precision), pole);
                for rings_ll in split {
                    let rings_ll: Vec<Vec<[f64; 2]>> = rings_ll
                        .iter()
                        .map(|r| {
                            r.iter()
                                .map(|p| [p[0], round_to(p[1], precision)])
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
        let feature_arcs: Vec<&FittedArc> = arcs_used.iter().map(|&a| &fitted[a]).collect();
        let met = feature_arcs.iter().all(|a| a.tolerance_met);
        let tw = feature_arcs
            .iter()
            .map(|a| a.two_way_rad)
            .fold(0.0, f64::max);
        let err = feature_arcs
            .iter()
            .map(|a| a.max_error_rad)
            .fold(0.0, f64::max);
        let stored: usize = feature_arcs.iter().map(|a| a.stored_numbers).sum();
        let n_in: usize = input_ll[fi].iter().flatten().map(Vec::len).sum();
        let n_out: usize = out_ll.iter().flatten().map(Vec::len).sum();
        let area_in = area::lonlat_polygons_area_m2(&input_ll[fi]);
        let area_out = area::lonlat_polygons_area_m2(&out_ll);
        let area_change = area::area_change(area_in, area_out);
        let shared = arcs_used
            .iter()
            .filter(|&&a| graph.arcs[a].uses > 1)
            .count();
        kept_total.extend(kept.iter().cloned());
        dropped_total.extend(dropped.iter().cloned());
        let geometry = if out_polys.is_empty() && !dropped.is_empty() {
            // Every polygon dropped: the feature stays, its geometry empty.
            json!({"type": "MultiPolygon", "coordinates": []})
        } else if out_polys.is_empty() {
            Value::Null
        } else if kind == "Polygon" && out_polys.len() == 1 {
            json!({"type": "Polygon", "coordinates": out_polys.pop().expect("one polygon")})
        } else {
            json!({"type": "MultiPolygon", "coordinates": out_polys})
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
        info.insert("arcs".into(), json!(arcs_used.len()));
        info.insert("shared_arcs".into(), json!(shared));
        info.insert("stored_numbers".into(), json!(stored));
        info.insert(
            "compression_ratio".into(),
            json!(compression_ratio(n_in, stored)),
        );
        info.insert("area_m2".into(), json!(round_to(area_out, 0)));
        info.insert("area_change".into(), json!(round_to(area_change, 9)));
        info.insert("antimeridian_split".into(), json!(split_any));
        info.insert("kept_rings".into(), json!(kept));
        if job.drop_small_rings {
            info.insert("dropped_rings".into(), json!(dropped));
        }
        info.insert(
            "tightened_arcs".into(),
            json!(feature_arcs
                .iter()
                .filter(|a| a.tolerance_rad < tol_rad)
                .count()),
        );
        info.insert("geometry".into(), json!(kind));
        info.insert("parts".into(), Value::Array(parts));
        let mut out = feature.as_object().cloned().unwrap_or_default();
        out.remove("bbox");
        out.insert("geometry".into(), geometry);
        let mut props = match out.remove("properties") {
            Some(Value::Object(p)) => p,
            _ => Map::new(),
        };
        props.insert("fit".into(), Value::Object(info));
        out.insert("properties".into(), Value::Object(props));
        features[fi] = Some(Value::Object(out));
        if !split_any && kept.is_empty() && dropped.is_empty() {
            feature_rings[fi] = Some(ring_uses_out);
        }
        max_two_way = max_two_way.max(tw);
        max_error = max_error.max(err);
        all_met &= met;
        area_change_max = area_change_max.max(area_change.abs());
        per_feature_stored += stored;
        input_points_total += n_in;
        output_points_total += n_out;
        stats.curves += by_feature[fi].iter().map(Vec::len).sum::<usize>();
        stats.input_points += n_in;
        stats.output_points += n_out;
        stats.max_error_m = stats.max_error_m.max(rad_to_m(err));
    }
    let stored_once: usize = fitted.iter().map(|a| a.stored_numbers).sum();
    stats.stored_numbers += stored_once;
    let shared_arcs = graph.arcs.iter().filter(|a| a.uses > 1).count();
    let mut report = json!({
        "topology": "shared",
        "tolerance_m": tolerance_m,
        "tolerance_met": all_met,
        "max_error_m": round_to(rad_to_m(max_error), 3),
        "two_way_distance_m": round_up_m(rad_to_m(max_two_way)),
        "polygon_features": polygon_kind.iter().filter(|k| k.is_some()).count(),
        "rings": graph.rings.len(),
        "vertices": graph.vertices.len(),
        "junctions": graph.junctions,
        "arc_count": graph.arcs.len(),
        "shared_arcs": shared_arcs,
        "input_points": input_points_total,
        "output_points": output_points_total,
        "stored_numbers": stored_once,
        "stored_numbers_per_feature_sum": per_feature_stored,
        "compression_ratio": compression_ratio(input_points_total, stored_once),
        "max_area_change": round_to(area_change_max, 9),
        "kept_rings": kept_total,
        "tightened_arcs": tightened,
        "crossings_left": crossings_left.iter().map(|&(a, b)| [a, b]).collect::<Vec<_>>(),
    });
    if job.drop_small_rings {
        report["dropped_rings"] = json!(dropped_total);
    }
    Ok(Coverage {
        features: features
            .into_iter()
            .map(|f| f.expect("every slot processed"))
            .collect(),
        members: doc.members,
        graph,
        arcs: fitted,
        feature_rings,
        report,
        stats,
    })
}

/// The pairs of arcs (a <= b; (a, a) for an arc and itself) that could cross in a way that
/// matters: arcs of one polygon (its exterior and holes: `groups` lists each polygon's rings),
/// and arcs ending at one junction.
fn arc_pairs(graph: &ArcGraph, groups: &[Vec<usize>]) -> Vec<(usize, usize)> {
    let mut pairs = BTreeSet::new();
    let mut at_vertex: std::collections::HashMap<usize, Vec<usize>> = Default::default();
    for (a, arc) in graph.arcs.iter().enumerate() {
        pairs.insert((a, a));
        if !arc.closed {
            for v in [arc.vertices[0], arc.vertices[arc.vertices.len() - 1]] {
                at_vertex.entry(v).or_default().push(a);
            }
        }
    }
    let mut add_all = |arcs: &[usize]| {
        for (i, &a) in arcs.iter().enumerate() {
            for &b in &arcs[i..] {
                pairs.insert((a.min(b), a.max(b)));
            }
        }
    };
    for rings in groups {
        let mut arcs: Vec<usize> = rings
            .iter()
            .flat_map(|&r| graph.rings[r].iter().map(|u| u.arc))
            .collect();
        arcs.sort_unstable();
        arcs.dedup();
        add_all(&arcs);
    }
    for arcs in at_vertex.values() {
        add_all(arcs);
    }
    pairs.into_iter().collect()
}

fn invalid(pointer: impl Into<String>, msg: impl Into<String>) -> EarthError {
    EarthError::new(pointer, Problem::InvalidGeoJson(msg.into()))
}

fn array_of<'a>(v: &'a Value, pointer: &str, what: &str) -> Result<&'a Vec<Value>, EarthError> {
    v.as_array().ok_or_else(|| {
        invalid(
            pointer,
            format!(
                "expected an array of {what}, got {}",
                super::curve::json_kind(v)
            ),
        )
    })
}

/// `Some("Polygon" | "MultiPolygon")` for a Feature object whose geometry is one.
fn polygon_type(feature: &Value) -> Option<&'static str> {
    if feature.get("type").and_then(Value::as_str) != Some("Feature") {
        return None;
    }
    match feature
        .get("geometry")
        .and_then(|g| g.get("type"))
        .and_then(Value::as_str)
    {
        Some("Polygon") => Some("Polygon"),
        Some("MultiPolygon") => Some("MultiPolygon"),
        _ => None,
    }
}

fn check_geometry_bbox(geometry: &Value, ptr: &str) -> Result<(), EarthError> {
    match geometry.get("bbox") {
        None => Ok(()),
        Some(b)
            if b.as_array().is_some_and(|a| {
                (a.len() == 4 || a.len() == 6) && a.iter().all(Value::is_number)
            }) =>
        {
            Ok(())
        }
        Some(_) => Err(invalid(
            format!("{ptr}/bbox"),
            "a bbox is an array of 4 or 6 numbers",
        )),
    }
}

/// A ring's output coordinates from its arcs: each arc's rounded dense coordinates in ring
/// order (reversed where used reversed), the junction shared by consecutive arcs once, the
/// first position repeated at the end. Coordinates at exactly ±180 degrees take the sign of
/// the ring around them.
fn ring_lonlat(uses: &[ArcUse], arcs: &[FittedArc]) -> Vec<[f64; 2]> {
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
fn is_plain(ring: &[[f64; 2]]) -> bool {
    ring.windows(2).all(|w| (w[1][0] - w[0][0]).abs() <= 180.0)
}

/// Fits one arc to the tolerance with pinned ends (see the module docs), rounds it, samples it
/// and measures the curve as returned.
fn fit_arc(
    points_in: &[[f64; 3]],
    closed: bool,
    tol_rad: f64,
    degree_cap: usize,
    parameterization: crate::sphere::Parameterization,
    job: &Job,
) -> Result<FittedArc, EarthError> {
    let mut rows = points_in.to_vec();
    let mut smooth_seam = false;
    if closed {
        // Start the closed curve at its sharpest corner: a C0 seam there costs nothing.
        rows.pop();
        let n = rows.len();
        let mut cyc = Vec::with_capacity(n + 2);
        cyc.push(rows[n - 1]);
        cyc.extend_from_slice(&rows);
        cyc.push(rows[0]);
        let set = PointSet::try_from_rows(&cyc).map_err(|e| sphere_error(e, "", &[]))?;
        let turns = turning_angles(&set);
        let (k, turn) = (0..n)
            .map(|i| (i, turns[i + 1]))
            .max_by(|a, b| a.1.total_cmp(&b.1))
            .expect("a ring has vertices");
        rows.rotate_left(k);
        rows.push(rows[0]);
        smooth_seam = turn < CORNER_ANGLE_RAD;
    }
    let n_in = if closed { rows.len() - 1 } else { rows.len() };
    let points = PointSet::try_from_rows(&rows).map_err(|e| sphere_error(e, "", &[]))?;
    let output = &job.output;
    let bound = rounding_bound_rad(output.precision);
    let dense_margin = AUTO_DEVIATION_FRACTION * tol_rad;
    let mut target = tolerance_target_rad(tol_rad, output.precision);
    let mut topts = ToleranceOptions {
        parameterization,
        max_control_points: Some(points.len()),
        pin_ends: true,
        measure_result: false,
        ..ToleranceOptions::default()
    };
    topts.degrees.retain(|&p| p <= degree_cap);
    let measure = |spline: &SphericalBSpline, params: &[f64]| -> Result<(f64, f64), EarthError> {
        let errs = pointwise_errors(spline, &points, params);
        let max = errs.iter().fold(0.0f64, |a, &b| a.max(b));
        let tw = two_way_distance(
            spline,
            &points,
            params,
            &TwoWayOptions::default()
                .with_precision_rad(0.01 * tol_rad)
                .with_max_evaluations(4_000_000 + 400 * points.len()),
        )
        .map_err(|e| sphere_error(e, "", &[]))?;
        Ok((max, tw.upper_rad))
    };
    let mut attempt = 0;
    let (spline, control_ll, rule, max_rad, tw_rad, seam) = loop {
        let r = fit_to_tolerance(&points, None, target, &topts)
            .map_err(|e| sphere_error(e, "", &[]))?;
        let (rounded, ll) =
            round_spline(&r.spline, output.precision).map_err(|e| sphere_error(e, "", &[]))?;
        let (max, tw) = measure(&rounded, &r.parameters)?;
        let mut best = (
            rounded,
            ll,
            r.knot_rule,
            max,
            tw,
            closed.then_some("corner"),
        );
        if closed && smooth_seam && r.spline.degree() >= 2 {
            // A C1 seam where the ring is smooth, kept when the tolerance still holds.
            if let Ok(c1) = close_seam(&r.spline, true) {
                if let Ok((rc, llc)) = round_spline(&c1, output.precision) {
                    let (m2, t2) = measure(&rc, &r.parameters)?;
                    if m2.max(t2) <= tol_rad {
                        best = (rc, llc, r.knot_rule, m2, t2, Some("smooth"));
                    }
                }
            }
        }
        let worst = best.3.max(best.4);
        if worst > tol_rad && r.tolerance_met && attempt == 0 {
            let lower = target - 2.0 * (worst - tol_rad) - bound;
            if lower > 0.25 * tol_rad {
                target = lower;
                attempt += 1;
                continue;
            }
        }
        break best;
    };
    // A closed arc is a whole ring: at least 4 positions (RFC 7946 §3.1.6).
    let sampling = match output.sampling {
        super::Sampling::Samples(n) if closed && n < 4 => super::Sampling::Samples(4),
        super::Sampling::SpacingM(spacing_m) if closed => super::Sampling::SpacingAndSamples {
            spacing_m,
            samples: 4,
        },
        s => s,
    };
    let dense = sample(
        &spline,
        sampling,
        dense_margin,
        sampling_start(spline.control_points().len()),
        job.limits.max_samples,
    )
    .map_err(|e| EarthError::new("", e.problem))?;
    let mut pts = dense.points.clone();
    let last = pts.len() - 1;
    // The ends are the (pinned, rounded) end control points exactly.
    let cps = spline.control_points();
    let (c0, c1) = (cps.get(0), cps.get(cps.len() - 1));
    pts[0] = [c0[0], c0[1], c0[2]];
    pts[last] = [c1[0], c1[1], c1[2]];
    let precision = output.precision;
    let mut dense_ll: Vec<[f64; 2]> = pts
        .iter()
        .map(|p| {
            let (lon, lat) = unit_to_lonlat(p);
            [round_to(lon, precision), round_to(lat, precision)]
        })
        .collect();
    dense_ll[0] = control_ll[0];
    dense_ll[last] = control_ll[control_ll.len() - 1];
    if closed {
        dense_ll[last] = dense_ll[0];
        pts[last] = pts[0];
    }
    // Neighbours that round to one position are written once: readers that join arcs (GDAL,
    // topojson-client) would otherwise keep a zero-length edge the GeoJSON output does not
    // have. The ends stay (a closed arc keeps both copies of its first position).
    let mut keep = vec![true; dense_ll.len()];
    let mut prev = 0;
    for i in 1..dense_ll.len() {
        if dense_ll[i] == dense_ll[prev] && i != last {
            keep[i] = false;
        } else {
            if dense_ll[i] == dense_ll[prev] && prev != 0 {
                keep[prev] = false;
            }
            prev = i;
        }
    }
    if keep.iter().any(|k| !k) {
        let mut k = keep.iter();
        dense_ll.retain(|_| *k.next().expect("one flag a position"));
        let mut k = keep.iter();
        pts.retain(|_| *k.next().expect("one flag a position"));
    }
    let stored = stored_numbers(&spline, rule);
    let met = max_rad.max(tw_rad) <= tol_rad;
    Ok(FittedArc {
        stored_numbers: stored,
        knot_rule: rule,
        control_ll,
        dense: pts,
        dense_ll,
        max_error_rad: max_rad,
        two_way_rad: tw_rad,
        tolerance_met: met,
        input_points: n_in,
        seam,
        sampling_deviation_rad: dense.max_deviation_rad,
        tolerance_rad: tol_rad,
        spline,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sphere::FitOptions;

    fn job(tolerance_m: f64) -> Job {
        Job {
            operation: Operation::FitToTolerance {
                options: FitOptions::faithful(),
                tolerance_m,
            },
            ..Job::fit(FitOptions::default())
        }
    }

    /// A wavy border from (0, 0) to (0, 2) shared by a west and an east square-ish feature.
    fn two_neighbours() -> Value {
        let border: Vec<[f64; 2]> = (0..=100)
            .map(|i| {
                let t = i as f64 / 100.0;
                [0.05 * (12.0 * t).sin(), 2.0 * t]
            })
            .collect();
        let mut west = border.clone();
        west.extend([[-2.0, 2.0], [-2.0, 0.0], border[0]]);
        let mut east: Vec<[f64; 2]> = border.iter().rev().copied().collect();
        east.extend([[2.0, 0.0], [2.0, 2.0], border[100]]);
        json!({"type": "FeatureCollection", "features": [
            {"type": "Feature", "id": "w", "properties": {"name": "west"}, "geometry": {"type": "Polygon", "coordinates": [west]}},
            {"type": "Feature", "properties": null, "geometry": {"type": "Polygon", "coordinates": [east]}},
            {"type": "Feature", "properties": {"p": 1}, "geometry": {"type": "Point", "coordinates": [5, 5]}}
        ]})
    }

    #[test]
    fn neighbours_share_identical_coordinates_and_arcs_are_stored_once() {
        let doc = Document::parse(two_neighbours(), false).unwrap();
        let c = fit_coverage(doc, &job(500.0)).unwrap();
        assert_eq!(c.graph.arcs.len(), 3);
        assert_eq!(c.report["shared_arcs"], 1);
        assert_eq!(c.report["tolerance_met"], true);
        let w = &c.features[0]["geometry"]["coordinates"][0];
        let e = &c.features[1]["geometry"]["coordinates"][0];
        let as_set = |r: &Value| -> std::collections::BTreeSet<String> {
            r.as_array()
                .unwrap()
                .iter()
                .map(|p| p.to_string())
                .collect()
        };
        let (ws, es) = (as_set(w), as_set(e));
        let common = ws.intersection(&es).count();
        // Every output point of the shared arc is in both rings, bit for bit.
        let shared = c.graph.arcs.iter().position(|a| a.uses == 2).unwrap();
        assert_eq!(common, c.arcs[shared].dense_ll.len());
        assert!(common > 2);
        // Arcs counted once: the dataset stores less than the features' sum.
        let once = c.report["stored_numbers"].as_u64().unwrap();
        let sum = c.report["stored_numbers_per_feature_sum"].as_u64().unwrap();
        assert_eq!(sum - once, c.arcs[shared].stored_numbers as u64);
        // Properties, ids and other features pass through.
        assert_eq!(c.features[0]["id"], "w");
        assert_eq!(c.features[0]["properties"]["name"], "west");
        assert_eq!(c.features[2]["geometry"]["coordinates"], json!([5, 5]));
        assert!(
            c.features[0]["properties"]["fit"]["area_change"]
                .as_f64()
                .unwrap()
                .abs()
                < 1e-3
        );
    }

    #[test]
    fn arcs_that_cross_their_neighbours_are_refitted_tighter() {
        // A corridor 445 to 890 m wide between two features, its borders wiggling by 5 km
        // together and sampled differently: at 2 km each border's fit may wander 2 km, so the
        // two cross; at an eighth of that (3 halvings) they cannot. (At 1.5 km they no longer
        // cross since polyline removals keep their corners on the line.)
        let wave = |n: usize, offset_deg: f64, extra: f64| -> Vec<[f64; 2]> {
            (0..=n)
                .map(|i| {
                    let t = i as f64 / n as f64;
                    [
                        3.0 * t,
                        offset_deg
                            + 0.045 * (9.0 * t).sin()
                            + 0.02 * (23.0 * t).sin()
                            + extra * (41.0 * t).sin(),
                    ]
                })
                .collect()
        };
        // 445 to 890 m apart.
        let (low, high) = (wave(97, 0.0, 0.0), wave(61, 0.006, 0.002));
        let mut a = low.clone();
        a.extend([[3.0, -1.0], [0.0, -1.0], low[0]]);
        let mut corridor: Vec<[f64; 2]> = low.clone();
        corridor.extend(high.iter().rev());
        corridor.push(low[0]);
        let mut b: Vec<[f64; 2]> = high.iter().rev().copied().collect();
        b.extend([[0.0, 1.0], [3.0, 1.0], high[high.len() - 1]]);
        let doc = json!({"type": "FeatureCollection", "features": [
            {"type": "Feature", "properties": {}, "geometry": {"type": "Polygon", "coordinates": [a]}},
            {"type": "Feature", "properties": {}, "geometry": {"type": "Polygon", "coordinates": [corridor]}},
            {"type": "Feature", "properties": {}, "geometry": {"type": "Polygon", "coordinates": [b]}}
        ]});
        let c = fit_coverage(Document::parse(doc, false).unwrap(), &job(2000.0)).unwrap();
        assert!(
            c.report["tightened_arcs"].as_u64().unwrap() >= 1,
            "{}",
            c.report
        );
        assert_eq!(c.report["crossings_left"], json!([]));
        assert_eq!(c.report["tolerance_met"], true);
        let tightened: Vec<&FittedArc> = c
            .arcs
            .iter()
            .filter(|a| a.tolerance_rad < m_to_rad(2000.0))
            .collect();
        assert!(tightened
            .iter()
            .all(|a| a.max_error_rad.max(a.two_way_rad) <= a.tolerance_rad));
        assert_eq!(
            c.features[1]["properties"]["fit"]["tightened_arcs"]
                .as_u64()
                .unwrap() as usize,
            tightened.len()
        );
    }

    #[test]
    fn an_island_is_one_closed_arc_smooth_across_its_seam() {
        let ring: Vec<[f64; 2]> = (0..=1000)
            .map(|i| {
                let a = std::f64::consts::TAU * (i % 1000) as f64 / 1000.0;
                [
                    10.0 + 2.0 * a.cos(),
                    40.0 + 1.5 * a.sin() + 0.1 * (3.0 * a).sin(),
                ]
            })
            .collect();
        let doc =
            Document::parse(json!({"type": "Polygon", "coordinates": [ring]}), false).unwrap();
        let c = fit_coverage(doc, &job(50.0)).unwrap();
        assert_eq!(c.graph.arcs.len(), 1);
        let a = &c.arcs[0];
        assert!(a.tolerance_met);
        assert_eq!(a.dense_ll.first(), a.dense_ll.last());
        assert_eq!(a.seam, Some("smooth"), "degree {}", a.spline.degree());
    }

    #[test]
    fn a_ring_that_bounds_no_area_is_kept() {
        // A ring that bounds no area is kept as it came and listed, as per-feature fitting
        // keeps it.
        let doc = Document::parse(
            json!({"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [0, 0], [1, 0], [0, 0]]]}),
            false,
        )
        .unwrap();
        let c = fit_coverage(doc, &job(10.0)).unwrap();
        assert_eq!(c.report["kept_rings"], json!(["/coordinates/0"]));
        assert_eq!(
            c.features[0]["geometry"]["coordinates"],
            json!([[[0.0, 0.0], [1.0, 0.0], [0.0, 0.0], [1.0, 0.0], [0.0, 0.0]]])
        );
        assert!(
            c.feature_rings[0].is_none(),
            "TopoJSON writes it as its own arcs"
        );
        // Bad positions are still errors, with their pointer.
        let doc = Document::parse(
            json!({"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [1, 95], [0, 0]]]}),
            false,
        )
        .unwrap();
        let e = fit_coverage(doc, &job(10.0)).unwrap_err();
        assert_eq!(e.pointer, "/coordinates/0/2/1");
    }
}
