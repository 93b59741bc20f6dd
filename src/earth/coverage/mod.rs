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
//!
//! The files follow [`fit_coverage`]'s steps: `read` (the document's polygon rings), [`arcs`]
//! (rings cut into arcs), `fitting` (every arc fitted, arcs that cross refitted tighter) with
//! `fit_arc` (one arc), `rebuild` (each polygon feature from its arcs) and `report` (the
//! dataset report).

pub mod arcs;

use crate::earth::curve::output::round_up_m;
use crate::earth::curve::tolerance_rule::ToleranceRule;
use crate::earth::error::EarthError;
use crate::earth::features::{Document, FeatureStats, Source};
use crate::earth::job::{Job, Operation};
use crate::earth::lonlat::{rad_to_m, round_to};
use crate::earth::polygon::small_rings;
use crate::sphere::compress::tolerance::KnotRule;
use crate::sphere::curve::bspline::SphericalBSpline;
use arcs::{ArcGraph, ArcUse};
use rayon::prelude::*;
use serde_json::{json, Map, Value};

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
    /// Length of the curve, radians.
    pub curve_length_rad: f64,
    /// Length of the arc's input polyline, radians.
    pub line_length_rad: f64,
    /// Within the tolerance ([`ToleranceRule::met`]).
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
    /// The parameters on `spline` of the arc's input positions as fitted (a closed arc's
    /// started at its sharpest corner), so that an arc can be refitted around a crossing only.
    pub params: Vec<f64>,
    /// A closed arc (a whole ring) whose fitted outline bounded no area, kept as a triangle of
    /// its own positions instead (`fit_arc::keep_arc`): kept so as an arc, it is judged for meetings
    /// with its neighbours as any arc is, and a tighter refit keeps more of its positions.
    pub small_ring: Option<small_rings::Kept>,
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
    /// Decimal steps in a step of the grid the positions are on
    /// ([`super::OutputOptions::grid_multiple`]).
    pub grid_multiple: u32,
    /// How long each step of the fit took.
    pub phases: Phases,
}

impl Coverage {
    /// The GeoJSON FeatureCollection: the features, the input's foreign members (without a
    /// stale `bbox`), and `topology` with the dataset report and every arc's report and
    /// spline (without the spline when the features carry only their geometry).
    pub fn into_feature_collection(self, carry: crate::earth::Carry) -> Value {
        let mut out = Map::new();
        out.insert("type".into(), json!("FeatureCollection"));
        for (k, v) in self.members {
            if k != "bbox" {
                out.insert(k, v);
            }
        }
        let mut report = self.report;
        report["arcs"] = Value::Array(
            self.arcs
                .iter()
                .map(|a| {
                    let mut v = arc_json(a);
                    if carry == crate::earth::Carry::Geometry {
                        v.as_object_mut().map(|m| m.remove("spline"));
                    }
                    v
                })
                .collect(),
        );
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

mod fit_arc;
mod fitting;
mod phases;
mod read;
mod rebuild;
mod report;
mod snap;
#[cfg(test)]
mod tests;
pub mod topojson;

use fit_arc::fit_arc;
use fitting::{fit_arcs, FittedArcs};
use read::read_coverage;
use rebuild::{Rebuild, RebuiltFeature};
use report::{dataset_report, Dataset, Totals};

pub use phases::Phases;

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
    let mut phases = Phases::new();
    let mut input = read_coverage(&doc, job)?;
    // The polygons' input coordinates are read (into `input`): freed now, on the pool while
    // the arc graph is built on this thread, for the steps below to reuse. Held to the end
    // they were the run's largest allocation (on the 10m countries about 90 MB of the peak's
    // 230), and the later steps' memory was fresh pages, each faulted in (docs/speed.md,
    // "tenth session").
    let mut doc = doc;
    let coordinates: Vec<Value> = doc
        .slots
        .iter_mut()
        .enumerate()
        .filter(|(fi, _)| input.polygon_kind[*fi].is_some())
        .filter_map(|(_, slot)| match &mut slot.source {
            Source::Feature { feature, .. } => feature
                .get_mut("geometry")
                .and_then(Value::as_object_mut)
                .and_then(|g| g.remove("coordinates")),
            Source::Spline(_) => None,
        })
        .collect();
    rayon::spawn(move || drop(coordinates));
    phases.lap("read rings");
    // Features other than polygons are fitted one by one on the decimal grid: the coarser
    // grid of a TopoJSON coverage is only taken when every feature is written on it.
    let grid_multiple = if input.polygon_kind.iter().any(Option::is_none) {
        1
    } else {
        job.output.grid_multiple
    };
    let graph = ArcGraph::build(&input.rings);
    phases.lap("arc graph");
    let tolerance = ToleranceRule::new(*tolerance_m, job.output.precision)
        .with_grid_multiple(grid_multiple)
        .with_snap_first(true);
    let tol_rad = tolerance.tol_rad;
    let FittedArcs {
        arcs: fitted,
        tightened,
        crossings_left,
        grid_multiple,
    } = fit_arcs(&graph, &input.sources, tolerance, options, job, &mut phases)?;
    // The rings rebuilt (kept small rings, antimeridian cuts) on the grid the arcs are on.
    let on_grid;
    let job = if grid_multiple == job.output.grid_multiple {
        job
    } else {
        let mut j = job.clone();
        j.output.grid_multiple = grid_multiple;
        on_grid = j;
        &on_grid
    };
    // Rebuild the polygon features from their rings' arcs.
    let mut by_feature: Vec<FeatureRings<'_>> = vec![Vec::new(); doc.slots.len()];
    for (ri, s) in input.sources.iter().enumerate() {
        let polys = &mut by_feature[s.feature];
        if polys.len() <= s.polygon {
            polys.resize(s.polygon + 1, Vec::new());
        }
        polys[s.polygon].push((ri, graph.rings[ri].as_slice()));
        debug_assert_eq!(polys[s.polygon].len(), s.ring + 1);
    }
    let mut features = std::mem::take(&mut input.features);
    let mut stats = input.stats;
    let rebuild = Rebuild {
        job,
        input: &input,
        graph: &graph,
        arcs: &fitted,
        tol_rad,
        tolerance_m: *tolerance_m,
    };
    let mut feature_rings: Vec<Option<PolygonArcs>> = vec![None; doc.slots.len()];
    let mut totals = Totals::new();
    // Each polygon feature rebuilt on its own (in parallel), then counted in order.
    let rebuilt: Vec<(usize, RebuiltFeature)> = doc
        .slots
        .par_iter()
        .enumerate()
        .filter_map(|(fi, slot)| {
            let kind = input.polygon_kind[fi]?;
            let Source::Feature { feature, .. } = &slot.source else {
                return None;
            };
            Some((fi, rebuild.feature(fi, kind, feature, &by_feature[fi])))
        })
        .collect();
    for (fi, mut rebuilt) in rebuilt {
        totals.add(&rebuilt);
        if job.carry == crate::earth::Carry::Geometry {
            if let Some(fit) = rebuilt.feature.pointer_mut("/properties/fit") {
                crate::earth::features::keep_geometry_only_members(fit);
            }
        }
        stats.curves += rebuilt.curves;
        stats.input_points += rebuilt.input_points;
        stats.output_points += rebuilt.output_points;
        stats.max_error_m = stats.max_error_m.max(rad_to_m(rebuilt.max_error_rad));
        features[fi] = Some(rebuilt.feature);
        feature_rings[fi] = rebuilt.rings;
    }
    phases.lap("rebuild features");
    let stored_once: usize = fitted.iter().map(|a| a.stored_numbers).sum();
    stats.stored_numbers += stored_once;
    let report = dataset_report(
        &totals,
        &Dataset {
            graph: &graph,
            tolerance_m: *tolerance_m,
            polygon_features: input.polygon_kind.iter().filter(|k| k.is_some()).count(),
            stored_once,
            tightened,
            crossings_left: &crossings_left,
            drop_small_rings: job.drop_small_rings,
        },
    );
    phases.lap("report");
    // The input, read and rebuilt, freed on every thread (it was parsed on every thread).
    let Document { members, slots } = doc;
    slots.into_par_iter().for_each(drop);
    drop(input);
    phases.lap("free input");
    Ok(Coverage {
        features: features
            .into_iter()
            .map(|f| f.expect("every slot processed"))
            .collect(),
        members,
        graph,
        arcs: fitted,
        feature_rings,
        report,
        stats,
        grid_multiple: job.output.grid_multiple,
        phases,
    })
}
