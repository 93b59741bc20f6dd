//! S^2 as the Earth: lon/lat <-> unit vectors, metres, the antimeridian, and GeoJSON in and out.
//!
//! Built on [`crate::sphere`] (which knows nothing of degrees or metres); used by the HTTP
//! service and the command line alike, so both give the same output for the same options.
//!
//! * [`lonlat`]: degrees <-> unit vectors, radians <-> metres (mean radius 6,371,008.8 m).
//! * [`polygon`]: what a ring needs to come back valid: [`polygon::antimeridian`] (output cut
//!   at ±180 degrees, RFC 7946 §3.1.9, and the poles), [`polygon::validity`] (rings that meet,
//!   judged and refitted), [`polygon::splice`] (a line refitted around a meeting only),
//!   [`polygon::small_rings`] (rings that collapse) and [`polygon::area`] (areas on the sphere).
//! * [`sampling`]: dense output of a curve (`samples`, `spacing_m`, or automatic).
//! * [`curve`]: one line or ring: positions parsed and checked, repeats dropped, fitted.
//! * [`job`]: the options of an operation, from what the user gave ([`RawOptions`]) to a
//!   checked [`Job`] ([`into_job`]): every rule about options is written there once, and the
//!   service, the command line and Python only fill a [`RawOptions`].
//! * [`error`]: [`EarthError`] (a JSON pointer and a [`Problem`]); [`Problem::CountOutOfRange`]
//!   names the limit and each front end words the option its own way.
//! * [`features`]: GeoJSON documents walked feature by feature ([`process_feature`]).
//! * [`json_out`]: output JSON whose long number arrays are written straight from `f64`.
//! * [`time`]: tracks in time: times read from the properties or the 4th coordinate and
//!   checked, the map between times and the curve parameter, speed and heading.
//! * [`coverage`]: the polygons of a document as one coverage (`topology=shared`): arcs between
//!   junctions, each fitted once, rings rebuilt from them; [`coverage::topojson`]: its TopoJSON
//!   output.
//!
//! # What happens to a GeoJSON document
//! * LineString and each part of a MultiLineString is fitted on its own; each Polygon and
//!   MultiPolygon ring is fitted as a closed curve (its end control points are pinned together,
//!   so the curve closes exactly at the ring's first vertex, with a possible corner there).
//!   Every other geometry (Point, MultiPoint, GeometryCollection, `null`) passes through
//!   unchanged, as do `properties`, `id`, foreign members and the order of features. A fitted
//!   feature gets `properties.fit` (overwriting one that is there) and loses a stale `bbox`.
//! * Positions are `[lon, lat]` or `[lon, lat, altitude]` (all of one kind per line). Longitude
//!   must be in [-180, 180] and latitude in [-90, 90]: values outside are rejected, never
//!   wrapped. The altitude is carried along the curve parameter: an output point at parameter t
//!   gets the altitude interpolated linearly between the input points around t.
//! * Repeated consecutive positions are dropped before fitting; their error (that of the kept
//!   copy) still counts in the metrics and in `input_points`. When fewer distinct positions
//!   remain than `degree + 1`, the degree is lowered to `distinct - 1`; one distinct position
//!   is an error.
//! * With [`TimeOptions::fit_in_time`] (`parameterization=time`) a line is fitted as position
//!   against time: each position's parameter is its time mapped to [0, 1] (never moved), so its
//!   error is the synchronized distance; only records repeated exactly (same time, same
//!   position) are dropped, a line ending where it starts stays open, and the dense output
//!   carries its times where the input had them ([`time`]).
//! * Errors are parametric geodesic distances in metres (METHOD.md): the distance from each
//!   input point to the curve at that point's parameter, measured with the spline as returned
//!   (control points rounded to `precision`).
//!
//! # Reuse (the batch CLI)
//! [`process_feature`] handles one Feature at a time and is all a streaming reader needs:
//! ```
//! use spherefit::earth::{process_feature, Job};
//! let feature = serde_json::json!({
//!     "type": "Feature", "id": 7, "properties": {"name": "wave"},
//!     "geometry": {"type": "LineString", "coordinates":
//!         (0..50).map(|i| [i as f64 * 0.1, (i as f64 * 0.05).sin()]).collect::<Vec<_>>()}
//! });
//! let out = process_feature(&feature, "/features/0", &Job::fit(Default::default())).unwrap();
//! assert_eq!(out.stats.curves, 1);
//! // Written as it is (its long number arrays straight from f64), or taken as a Value:
//! let text = serde_json::to_string(&out.feature).unwrap();
//! let value = out.feature.into_value();
//! assert_eq!(text, value.to_string());
//! assert_eq!(value["id"], 7);
//! assert!(value["properties"]["fit"]["max_error_m"].as_f64().unwrap() < 5_000.0);
//! ```

pub mod coverage;
pub mod curve;
pub mod error;
pub mod features;
pub mod job;
pub mod json_out;
pub mod lonlat;
pub mod polygon;
pub mod sampling;
pub mod time;

pub use error::{EarthError, Problem};
pub use features::{
    evaluate_spline_document, process_feature, process_geometry, Document, FeatureSlot,
    FeatureStats, ProcessedFeature, Source,
};
pub use job::{
    check_degree, check_fit_options, check_target_max_error_rad, check_tolerance, into_job,
    parse_json_number, precision_for_tolerance, Carry, InterpolateSettings, Job, Limits, Operation,
    OperationKind, OptionType, OutputFormat, OutputOptions, ParameterizationOption, ParseError,
    RawOptions, TimeOptions, Topology, DEFAULT_PRECISION, MAX_PRECISION,
    PRECISION_SHARE_OF_TOLERANCE,
};
pub use json_out::JsonOut;
pub use lonlat::{lonlat_to_unit, m_to_rad, rad_to_m, unit_to_lonlat, LonLat, EARTH_RADIUS_M};
pub use sampling::Sampling;
pub use time::{TimeFormat, TimeMap, TimeSource};
