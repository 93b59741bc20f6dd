//! A coverage's input: the document read. Features that are not polygons are processed one
//! by one as without `topology=shared`; the rings of the polygon features (rejoined where they
//! came cut at ±180) are read in order, each with where it came from.

use crate::earth::coverage::arcs::InputRing;
use crate::earth::curve::positions::prepare_line;
use crate::earth::error::{EarthError, Problem};
use crate::earth::features::{array_at, check_bbox, invalid, FeatureSlot};
use crate::earth::features::{process_feature, Document, FeatureStats, Source};
use crate::earth::job::Job;
use crate::earth::lonlat::unit_to_lonlat;
use crate::earth::polygon::antimeridian;
use rayon::prelude::{IndexedParallelIterator, IntoParallelRefIterator, ParallelIterator};
use serde_json::{Map, Value};

/// A polygon ring of the input and where it came from.
pub(super) struct RingSource {
    pub(super) feature: usize,
    pub(super) polygon: usize,
    pub(super) ring: usize,
    pub(super) pointer: String,
}

/// The document as a coverage reads it.
pub(super) struct CoverageInput {
    /// The output of each slot that is not a polygon feature; `None` for polygon features
    /// until they are rebuilt from arcs.
    pub(super) features: Vec<Option<Value>>,
    /// For each slot: `Polygon` or `MultiPolygon` (after rejoining) for a polygon feature.
    pub(super) polygon_kind: Vec<Option<&'static str>>,
    /// Counters of the features already processed.
    pub(super) stats: FeatureStats,
    /// The polygon rings, in order.
    pub(super) rings: Vec<InputRing>,
    /// Where each ring came from.
    pub(super) sources: Vec<RingSource>,
    /// Each polygon feature's rings as read, `[lon, lat]`, by polygon (for areas).
    pub(super) input_ll: Vec<Vec<Vec<Vec<[f64; 2]>>>>,
    /// The pole each rejoined polygon of a feature was closed along in its cut-form input.
    pub(super) polygon_poles: Vec<Vec<Option<f64>>>,
}

/// One slot of the document as read: a feature processed as usual, or a polygon feature's
/// rings.
enum SlotRead {
    Processed(Value, FeatureStats),
    Polygon {
        kind: &'static str,
        /// Its rings in order, each with where it came from.
        rings: Vec<(InputRing, RingSource)>,
        /// Its rings as read, `[lon, lat]`, by polygon.
        input_ll: Vec<Vec<Vec<[f64; 2]>>>,
        poles: Vec<Option<f64>>,
    },
}

/// Reads `doc` for a coverage (see [`CoverageInput`]): the slots in parallel, the first error
/// in document order returned.
pub(super) fn read_coverage(doc: &Document, job: &Job) -> Result<CoverageInput, EarthError> {
    let read: Vec<Result<SlotRead, EarthError>> = doc
        .slots
        .par_iter()
        .enumerate()
        .map(|(fi, slot)| read_slot(fi, slot, job))
        .collect();
    let n = doc.slots.len();
    let mut input = CoverageInput {
        features: vec![None; n],
        polygon_kind: vec![None; n],
        stats: FeatureStats::default(),
        rings: Vec::new(),
        sources: Vec::new(),
        input_ll: vec![Vec::new(); n],
        polygon_poles: vec![Vec::new(); n],
    };
    for (fi, r) in read.into_iter().enumerate() {
        match r? {
            SlotRead::Processed(feature, stats) => {
                input.stats.merge(&stats);
                input.features[fi] = Some(feature);
            }
            SlotRead::Polygon {
                kind,
                rings,
                input_ll,
                poles,
            } => {
                for (ring, source) in rings {
                    input.rings.push(ring);
                    input.sources.push(source);
                }
                input.input_ll[fi] = input_ll;
                input.polygon_poles[fi] = poles;
                input.polygon_kind[fi] = Some(kind);
            }
        }
    }
    Ok(input)
}

/// Reads slot `fi` (see [`SlotRead`]).
fn read_slot(fi: usize, slot: &FeatureSlot, job: &Job) -> Result<SlotRead, EarthError> {
    job.cancel
        .check()
        .map_err(|e| EarthError::new(slot.pointer.clone(), Problem::Fit(e)))?;
    let kind = match &slot.source {
        Source::Feature { feature, .. } => polygon_type(feature),
        Source::Spline(_) => None,
    };
    let Some(kind) = kind else {
        let out = slot.process(job)?;
        return Ok(SlotRead::Processed(out.feature.into_value(), out.stats));
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
    let bare: Map<String, Value> = feature
        .as_object()
        .expect("polygon_type only accepts objects")
        .iter()
        .map(|(k, v)| {
            let v = if k == "geometry" {
                Value::Null
            } else {
                v.clone()
            };
            (k.clone(), v)
        })
        .collect();
    process_feature(&Value::Object(bare), &slot.pointer, job)?;
    let geometry = &feature["geometry"];
    if let Some(g) = geometry.as_object() {
        check_bbox(g, geometry_pointer)?;
    }
    let cptr = format!("{geometry_pointer}/coordinates");
    let coords = geometry
        .get("coordinates")
        .ok_or_else(|| invalid(geometry_pointer, format!("a {kind} needs \"coordinates\"")))?;
    let polygons: Vec<(String, &Value)> = if kind == "Polygon" {
        vec![(cptr.clone(), coords)]
    } else {
        array_at(coords, &cptr, "polygons")?
            .iter()
            .enumerate()
            .map(|(i, p)| (format!("{cptr}/{i}"), p))
            .collect()
    };
    // Polygons cut at ±180 are rejoined into rings on the sphere, as per-feature fitting
    // does (antimeridian::rejoin).
    let rejoined = antimeridian::rejoin::rejoin_cut_polygons(&polygons)
        .transpose()
        .map_err(crate::earth::features::no_area_on_the_sphere)?;
    let kind = match &rejoined {
        Some(p) if kind == "Polygon" && p.len() == 1 => "Polygon",
        Some(_) => "MultiPolygon",
        None => kind,
    };
    let mut ring_sets: Vec<Vec<(String, &Value)>> = Vec::with_capacity(polygons.len());
    let mut poles = Vec::new();
    match &rejoined {
        Some(polys) => {
            for poly in polys {
                ring_sets.push(poly.rings.iter().map(|(p, r)| (p.clone(), r)).collect());
            }
            poles = polys.iter().map(|p| p.pole).collect();
        }
        None => {
            for (pptr, poly) in &polygons {
                ring_sets.push(
                    array_at(poly, pptr, "rings")?
                        .iter()
                        .enumerate()
                        .map(|(ri, ring)| (format!("{pptr}/{ri}"), ring))
                        .collect(),
                );
            }
        }
    }
    let mut rings = Vec::new();
    let mut input_ll = Vec::with_capacity(ring_sets.len());
    for (pi, poly_rings) in ring_sets.into_iter().enumerate() {
        let mut poly_ll = Vec::new();
        for (ri, (rptr, ring)) in poly_rings.into_iter().enumerate() {
            // A ring of one distinct position bounds no area: read here, kept as it came below.
            let line = match prepare_line(ring, &rptr, true, None) {
                Ok((line, _, _)) => line,
                Err(e) if matches!(e.problem, Problem::TooFewPoints { .. }) => {
                    crate::earth::curve::positions::parse_positions(ring, &rptr)?
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
            rings.push((
                InputRing {
                    points: line.points,
                },
                RingSource {
                    feature: fi,
                    polygon: pi,
                    ring: ri,
                    pointer: rptr,
                },
            ));
        }
        input_ll.push(poly_ll);
    }
    Ok(SlotRead::Polygon {
        kind,
        rings,
        input_ll,
        poles,
    })
}

/// `Some("Polygon" | "MultiPolygon")` for a Feature object whose geometry is one.
pub(super) fn polygon_type(feature: &Value) -> Option<&'static str> {
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
