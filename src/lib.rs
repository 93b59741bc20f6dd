//! # spherefit
//!
//! Smooth spline curves through and near ordered points on the sphere S^n.
//!
//! Layers, dependencies pointing one way:
//! * [`sphere`]: math on S^n, knowing nothing of GeoJSON, HTTP or metres:
//!   [`sphere::point`] (unit vectors, SLERP, log/exp maps), [`sphere::bspline`] (de Boor with
//!   SLERP and contribution coefficients), [`sphere::knots`] (parameters, adaptive knots),
//!   [`mod@sphere::fit`] (GLS-PIA, `Solver::GaussNewton`), banded Cholesky in
//!   [`sphere::banded`], [`sphere::metrics`] (geodesic errors),
//!   [`sphere::beta`] and [`sphere::bezier`] (Beta-spline interpolation, Bézier curves),
//!   [`sphere::tolerance`] and [`sphere::simplify`] (fitting to a tolerance, spherical
//!   Douglas–Peucker), [`sphere::document`] (the JSON documents).
//! * [`earth`]: S^2 as the Earth: lon/lat, metres, the antimeridian, GeoJSON in and out.
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

pub mod cli;
pub mod earth;
pub mod service;
pub mod sphere;
