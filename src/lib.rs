//! # spherefit
//!
//! Smooth spline curves through and near ordered points on the sphere S^n.
//!
//! Layers, dependencies pointing one way:
//! * [`sphere`]: math on S^n, knowing nothing of GeoJSON, HTTP or metres, in folders by concern:
//!   [`sphere::geometry`] (unit vectors, SLERP, log/exp maps), [`sphere::curve`] (the
//!   B-spline with de Boor and contribution coefficients, Bézier curves, the
//!   [`SphericalCurve`](sphere::SphericalCurve) trait), [`mod@sphere::fit`] (parameters and
//!   knots, GLS-PIA, `Solver::GaussNewton`, geodesic error metrics), [`mod@sphere::interpolate`]
//!   (Beta-spline interpolation), [`sphere::compress`] (fitting to a tolerance, spherical
//!   Douglas–Peucker and its time-aware form TD-TR) and `sphere::linalg` (band matrix solvers,
//!   internal).
//! * [`document`]: the S^n JSON documents (points in, splines and fit results out) shared by the
//!   CLI and the service.
//! * [`earth`]: S^2 as the Earth: lon/lat, metres, the antimeridian, GeoJSON in and out, and
//!   tracks in time ([`earth::time`]: times read and checked, position as a function of time,
//!   speed and heading).
//!   polygon coverages fitted with shared borders ([`earth::coverage`]: arcs and junctions,
//!   each arc fitted once; [`earth::coverage::topojson`]: TopoJSON output).
//! * [`service`]: the HTTP service (axum): `/v1/fit`, `/v1/interpolate`, `/v1/evaluate` and the
//!   S^n documents under `/v1/sphere/`.
//! * [`cli`]: the command line.
//!
//! ```
//! use spherefit::sphere::{fit, FitOptions, PointSet, SphericalCurve};
//! // A wavy line on S^2 as unit vectors.
//! let rows: Vec<Vec<f64>> = (0..100)
//!     .map(|i| {
//!         let lon = i as f64 * 0.01;
//!         let lat = 0.05 * (10.0 * lon).sin();
//!         vec![lat.cos() * lon.cos(), lat.cos() * lon.sin(), lat.sin()]
//!     })
//!     .collect();
//! let points = PointSet::try_from_rows(&rows).unwrap();
//! let report = fit(&points, None, &FitOptions::default().with_control_points(12)).unwrap();
//! assert!(report.metrics.max_error_rad < 1e-3);
//! let (_params, dense) = report.spline.sample(500);
//! assert_eq!(dense.len(), 500);
//! ```

#[cfg(feature = "cli")]
pub mod cli;
pub mod document;
pub mod earth;
#[cfg(feature = "formats")]
pub mod formats;
#[cfg(feature = "service")]
pub mod service;
pub mod sphere;

pub(crate) use sphere::geometry::point::with_dim;
