//! A coverage's dataset report (the GeoJSON collection's `topology` member).

use crate::earth::coverage::arcs::ArcGraph;
use crate::earth::coverage::rebuild::RebuiltFeature;
use crate::earth::curve::output::{compression_ratio, round_up_m};
use crate::earth::lonlat::{rad_to_m, round_to};

use serde_json::{json, Value};

/// Sums and maxima over the rebuilt polygon features.
pub(super) struct Totals {
    max_two_way_rad: f64,
    max_error_rad: f64,
    all_met: bool,
    max_area_change: f64,
    per_feature_stored: usize,
    input_points: usize,
    output_points: usize,
    kept: Vec<String>,
    dropped: Vec<String>,
}

impl Totals {
    /// Before any feature: every tolerance met.
    pub(super) fn new() -> Totals {
        Totals {
            max_two_way_rad: 0.0,
            max_error_rad: 0.0,
            all_met: true,
            max_area_change: 0.0,
            per_feature_stored: 0,
            input_points: 0,
            output_points: 0,
            kept: Vec::new(),
            dropped: Vec::new(),
        }
    }

    /// Adds a rebuilt feature.
    pub(super) fn add(&mut self, f: &RebuiltFeature) {
        self.max_two_way_rad = self.max_two_way_rad.max(f.two_way_rad);
        self.max_error_rad = self.max_error_rad.max(f.max_error_rad);
        self.all_met &= f.tolerance_met;
        self.max_area_change = self.max_area_change.max(f.area_change.abs());
        self.per_feature_stored += f.stored_numbers;
        self.input_points += f.input_points;
        self.output_points += f.output_points;
        self.kept.extend(f.kept.iter().cloned());
        self.dropped.extend(f.dropped.iter().cloned());
    }
}

/// What the dataset report says beside the totals.
pub(super) struct Dataset<'a> {
    pub(super) graph: &'a ArcGraph,
    pub(super) tolerance_m: f64,
    /// Polygon features read.
    pub(super) polygon_features: usize,
    /// Numbers stored by the arcs, each arc once.
    pub(super) stored_once: usize,
    /// Arcs fitted tighter than the tolerance.
    pub(super) tightened: usize,
    pub(super) crossings_left: &'a [(usize, usize)],
    pub(super) drop_small_rings: bool,
}

/// The dataset report.
pub(super) fn dataset_report(t: &Totals, d: &Dataset<'_>) -> Value {
    let graph = d.graph;
    let shared_arcs = graph.arcs.iter().filter(|a| a.uses > 1).count();
    let mut report = json!({
        "topology": "shared",
        "tolerance_m": d.tolerance_m,
        "tolerance_met": t.all_met,
        "max_error_m": round_to(rad_to_m(t.max_error_rad), 3),
        "two_way_distance_m": round_up_m(rad_to_m(t.max_two_way_rad)),
        "polygon_features": d.polygon_features,
        "rings": graph.rings.len(),
        "vertices": graph.vertices.len(),
        "junctions": graph.junctions,
        "arc_count": graph.arcs.len(),
        "shared_arcs": shared_arcs,
        "input_points": t.input_points,
        "output_points": t.output_points,
        "stored_numbers": d.stored_once,
        "stored_numbers_per_feature_sum": t.per_feature_stored,
        "compression_ratio": compression_ratio(t.input_points, d.stored_once),
        "max_area_change": round_to(t.max_area_change, 9),
        "kept_rings": t.kept,
        "tightened_arcs": d.tightened,
        "crossings_left": d.crossings_left.iter().map(|&(a, b)| [a, b]).collect::<Vec<_>>(),
    });
    if d.drop_small_rings {
        report["dropped_rings"] = json!(t.dropped);
    }
    report
}
