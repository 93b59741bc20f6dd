//! The four curve-fitting methods the GLS-PIA paper compares itself with in its §6.2 (Table 3,
//! Figures 9–12), on S^n of any dimension, beside GLS-PIA itself, behind one entry point
//! ([`fit_with`]) and one result type ([`MethodFit`]):
//!
//! * [`Method::JuppKent`]: unwrapping onto the tangent space by rolling, a Euclidean cubic
//!   smoothing spline, wrapping back (Jupp & Kent 1987) — [`jupp_kent`];
//! * [`Method::Samir`]: gradient descent on a discretised curve with the gradient of the
//!   second-order Palais metric (Samir, Absil, Srivastava & Klassen 2012) — [`samir`];
//! * [`Method::Cbc`] and [`Method::Bcc`]: composite Bézier-like curves and blended cubic
//!   splines (Gousenbourger, Massart & Absil 2018) — [`bezier_blend`].
//!
//! Every method fits the same problem: ordered points `p_i` with parameters `t_i` in [0, 1]
//! (chord length by geodesic distance, as GLS-PIA, or the caller's), and is judged by the
//! paper's Max_Error and Mean_Error (eqs. 35–36): the angle between `p_i` and the curve at
//! `t_i`. Each returns the curve at the data parameters and as dense samples, so any error
//! can be recomputed from the output.
//!
//! Where a method has a smoothing weight, the loss is written the same way for all of them:
//! `½ Σ d²(γ(t_i), p_i) + (λ/2) ∫₀¹ ‖D²γ/dt²‖² dt` ([`MethodOptions::lambda`]).

pub mod bezier_blend;
pub(crate) mod frame;
pub mod jupp_kent;
pub mod samir;

use crate::sphere::curve::bspline::SphericalBSpline;
use crate::sphere::fit::knots::{normalize_parameters, parameters};
use crate::sphere::fit::metrics::{ErrorMetrics, ErrorSums};
use crate::sphere::fit::options::{default_control_points, FitOptions};
use crate::sphere::fit::solve::fit;
use crate::sphere::geometry::point::{angle_between, Arc, Dynamic, PointSet};
use crate::sphere::SphereError;
use std::time::{Duration, Instant};

/// Most dense samples a fit may be asked for (each is one point of the output).
pub const MAX_SAMPLES: usize = 1_000_000;

/// Dense samples written when the caller does not say.
pub const DEFAULT_SAMPLES: usize = 1001;

/// The default smoothing weight λ of Samir et al. and of CBC/BCC (see the module docs): small
/// enough that, at the data's scale (parameters in [0, 1], data term summed over the points),
/// the fit is driven by the data and λ only regularises; none of the three papers fixes one.
pub const DEFAULT_LAMBDA: f64 = 1e-6;

/// Which method fits the curve.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Method {
    /// The paper's own method (a spherical B-spline by GLS-PIA, [`crate::sphere::fit()`]).
    #[default]
    GlsPia,
    /// Jupp–Kent unwrapping ([`jupp_kent`]).
    JuppKent,
    /// Samir et al.'s Palais-metric gradient descent ([`samir`]).
    Samir,
    /// Gousenbourger et al.'s composite Bézier-like curve (`cbc`).
    Cbc,
    /// Gousenbourger et al.'s blended cubic spline (`bcc`).
    Bcc,
}

from_names!(Method, "method", "gls-pia, jupp-kent, samir, cbc or bcc" {
    "gls-pia" => GlsPia,
    "jupp-kent" => JuppKent,
    "samir" => Samir,
    "cbc" => Cbc,
    "bcc" => Bcc,
});

impl Method {
    /// Every method, the paper's first.
    pub const ALL: [Method; 5] = [
        Method::GlsPia,
        Method::JuppKent,
        Method::Samir,
        Method::Cbc,
        Method::Bcc,
    ];

    /// The name used in options and reports.
    pub fn name(self) -> &'static str {
        match self {
            Method::GlsPia => "gls-pia",
            Method::JuppKent => "jupp-kent",
            Method::Samir => "samir",
            Method::Cbc => "cbc",
            Method::Bcc => "bcc",
        }
    }
}

/// How Jupp–Kent chooses the smoothing of its Euclidean spline.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Smoothing {
    /// Generalised cross-validation (Craven & Wahba 1979), as Jupp & Kent suggest.
    #[default]
    Gcv,
    /// A fixed weight α of `Σ (y_i − g(t_i))² + α ∫ g''²` on parameters in [0, 1].
    Lambda(f64),
    /// The α whose smoother has this many equivalent degrees of freedom (the trace of the hat
    /// matrix, per coordinate): between 2 (a straight line) and the number of points.
    DegreesOfFreedom(f64),
}

/// Options of the comparison methods. `Default` is what the front ends use.
#[derive(Clone, Debug)]
pub struct MethodOptions {
    /// The budget of free points: GLS-PIA's control points; CBC and BCC use the largest number
    /// of segments `K` whose `2K + 2` degrees of freedom fit in it. `None`: a quarter of the
    /// points (GLS-PIA's default).
    pub control_points: Option<usize>,
    /// Jupp–Kent's smoothing.
    pub smoothing: Smoothing,
    /// The smoothing weight λ of Samir et al., CBC and BCC (≥ 0; CBC/BCC need it > 0 only
    /// when a segment holds no data).
    pub lambda: f64,
    /// Nodes of Samir et al.'s discretised curve, evenly spaced in parameter, 3 to
    /// [`samir::MAX_NODES`]; `None`: one per data point (at least 3, at most
    /// [`samir::MAX_NODES`]).
    pub nodes: Option<usize>,
    /// Most iterations (Jupp–Kent rounds, Samir gradient steps); `None`: 50 rounds, 100,000
    /// steps.
    pub iterations: Option<usize>,
    /// Stop the iterative methods (Jupp–Kent, Samir) after this much wall time, as the paper
    /// does with the time of 30 GLS-PIA iterations. `None`: run to convergence.
    pub time_budget: Option<Duration>,
    /// Dense samples of the curve in the result.
    pub samples: usize,
    /// GLS-PIA's options (its knots, iterations, solver, cancellation); the control points
    /// come from [`MethodOptions::control_points`].
    pub gls_pia: FitOptions,
}

impl Default for MethodOptions {
    fn default() -> Self {
        MethodOptions {
            control_points: None,
            smoothing: Smoothing::Gcv,
            lambda: DEFAULT_LAMBDA,
            nodes: None,
            iterations: None,
            time_budget: None,
            samples: DEFAULT_SAMPLES,
            gls_pia: FitOptions::default(),
        }
    }
}

impl MethodOptions {
    with_fields! {
        /// Sets the budget of free points (GLS-PIA's control points).
        with_control_points(control_points: usize) = Some;
        /// Sets Jupp–Kent's smoothing.
        with_smoothing(smoothing: Smoothing);
        /// Sets the smoothing weight λ of Samir et al., CBC and BCC.
        with_lambda(lambda: f64);
        /// Sets the nodes of Samir et al.'s discretised curve.
        with_nodes(nodes: usize) = Some;
        /// Sets the most iterations of the iterative methods.
        with_iterations(iterations: usize) = Some;
        /// Sets the time budget of the iterative methods.
        with_time_budget(time_budget: Duration) = Some;
        /// Sets the number of dense samples.
        with_samples(samples: usize);
    }
}

/// Everything that can be wrong with a comparison fit.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum CompareError {
    /// The input points or a geometric step (as for the other fits).
    #[error(transparent)]
    Sphere(#[from] SphereError),
    /// An option out of its range.
    #[error("{option}: {value} is out of range: {rule}")]
    InvalidOption {
        /// The option's name (`lambda`, `samples`, `smoothing`, `nodes`, `iterations`,
        /// `control_points`).
        option: &'static str,
        /// The value given.
        value: String,
        /// The range it must be in.
        rule: String,
    },
    /// Two consecutive points with the same parameter, which a smoothing spline in the
    /// parameter cannot separate.
    #[error("points {} and {index} have the same parameter ({parameter}): Jupp-Kent's smoothing spline needs increasing parameters; remove the repeated point", index.saturating_sub(1))]
    RepeatedParameter {
        /// The second point of the pair.
        index: usize,
        /// Their parameter.
        parameter: f64,
    },
    /// No base point for the tangent space: the points' mean direction vanishes (they are
    /// spread evenly around the sphere), or a point is (nearly) antipodal to it.
    #[error("no tangent space holds the data: {reason}; CBC maps every point to one tangent space, use bcc, jupp-kent or gls-pia")]
    NoTangentBase {
        /// Why.
        reason: String,
    },
    /// A linear system of the method had no unique solution (too few points for its
    /// degrees of freedom, or λ = 0 with an empty segment).
    #[error("{method}: {reason}")]
    Singular {
        /// The method.
        method: &'static str,
        /// What to change.
        reason: String,
    },
}

/// A fitted curve, however the method represents it.
#[derive(Clone, Debug)]
pub struct MethodFit {
    /// The method.
    pub method: Method,
    /// The data parameters in [0, 1].
    pub parameters: Vec<f64>,
    /// The curve at each data parameter.
    pub fitted: PointSet,
    /// Max / mean / RMS of the angle between each point and [`MethodFit::fitted`], radians
    /// (the paper's Max_Error and Mean_Error).
    pub metrics: ErrorMetrics,
    /// Dense sample parameters, evenly spaced over [0, 1].
    pub sample_parameters: Vec<f64>,
    /// The curve at [`MethodFit::sample_parameters`].
    pub samples: PointSet,
    /// Iterations made: GLS-PIA updates, Jupp–Kent rounds, Samir steps; 0 for CBC and BCC,
    /// which solve one linear system per fit.
    pub iterations: usize,
    /// Whether an iterative method stopped because it converged (true for CBC and BCC).
    pub converged: bool,
    /// The free points of the representation: control points (GLS-PIA), Bézier degrees of
    /// freedom `2K + 2` (CBC, BCC), nodes (Samir), and for Jupp–Kent the equivalent degrees
    /// of freedom of its smoother, rounded.
    pub free_points: usize,
    /// The spline, for GLS-PIA.
    pub spline: Option<SphericalBSpline>,
    /// Wall time of the fit (samples included).
    pub elapsed: Duration,
}

/// Fits `points` with `method`. `given_params` (timestamps) are normalised to [0, 1]; without
/// them the parameters are chord lengths by geodesic distance.
///
/// # Errors
/// Invalid points or parameters ([`CompareError::Sphere`]), options out of range, or the
/// method-specific failures of [`CompareError`].
///
/// # Example
/// ```
/// use spherefit::sphere::compare::{fit_with, Method, MethodOptions};
/// use spherefit::sphere::PointSet;
/// let rows: Vec<[f64; 3]> = (0..40).map(|i| { let a = 0.05 * i as f64; [a.cos(), a.sin(), 0.0] }).collect();
/// let points = PointSet::try_from_rows(&rows).unwrap();
/// let f = fit_with(Method::Cbc, &points, None, &MethodOptions::default()).unwrap();
/// assert!(f.metrics.max_error_rad < 1e-9);
/// ```
pub fn fit_with(
    method: Method,
    points: &PointSet,
    given_params: Option<&[f64]>,
    options: &MethodOptions,
) -> Result<MethodFit, CompareError> {
    let start = Instant::now();
    check_options(options)?;
    let n = points.len();
    let need = 4;
    if n < need {
        return Err(SphereError::TooFewPoints { got: n, need }.into());
    }
    points.check_no_antipodal_neighbours()?;
    let params = match given_params {
        Some(t) => normalize_parameters(t, n)?,
        None => parameters(points, options.gls_pia.parameterization)?,
    };
    let budget = options
        .control_points
        .unwrap_or_else(|| default_control_points(n, 3));
    if budget < 4 || budget > n {
        return Err(CompareError::InvalidOption {
            option: "control_points",
            value: budget.to_string(),
            rule: format!("use 4 to the number of points ({n})"),
        });
    }
    let sample_parameters = crate::sphere::curve::even_parameters((0.0, 1.0), options.samples);
    let mut spline = None;
    let fitted_curve: Fitted = match method {
        Method::GlsPia => {
            let mut o = options.gls_pia.clone();
            o.control_points = Some(budget);
            let r = fit(points, given_params, &o)?;
            let fitted = r.spline.evaluate_many(&r.parameters);
            let samples = r.spline.evaluate_many(&sample_parameters);
            let out = Fitted {
                fitted,
                samples,
                iterations: r.iterations,
                converged: r.converged,
                free_points: r.spline.control_points().len(),
            };
            spline = Some(r.spline);
            out
        }
        Method::JuppKent => jupp_kent::fit(points, &params, options, &sample_parameters)?,
        Method::Samir => samir::fit(points, &params, options, &sample_parameters)?,
        Method::Cbc => bezier_blend::cbc(points, &params, budget, options, &sample_parameters)?,
        Method::Bcc => bezier_blend::bcc(points, &params, budget, options, &sample_parameters)?,
    };
    let metrics = errors(points, &fitted_curve.fitted);
    if !metrics.max_error_rad.is_finite() {
        return Err(SphereError::NonFinite {
            what: "fitted curve",
            why: format!("{} produced a non-finite point", method.name()),
        }
        .into());
    }
    Ok(MethodFit {
        method,
        parameters: params,
        fitted: fitted_curve.fitted,
        metrics,
        sample_parameters,
        samples: fitted_curve.samples,
        iterations: fitted_curve.iterations,
        converged: fitted_curve.converged,
        free_points: fitted_curve.free_points,
        spline,
        elapsed: start.elapsed(),
    })
}

/// What a method hands back to [`fit_with`].
pub(crate) struct Fitted {
    pub(crate) fitted: PointSet,
    pub(crate) samples: PointSet,
    pub(crate) iterations: usize,
    pub(crate) converged: bool,
    pub(crate) free_points: usize,
}

/// The ranges of the options, checked before any work.
fn check_options(o: &MethodOptions) -> Result<(), CompareError> {
    let bad = |option: &'static str, value: String, rule: &str| {
        Err(CompareError::InvalidOption {
            option,
            value,
            rule: rule.to_string(),
        })
    };
    if !(o.lambda.is_finite() && o.lambda >= 0.0) {
        return bad("lambda", o.lambda.to_string(), "use a finite number >= 0");
    }
    if o.samples < 2 || o.samples > MAX_SAMPLES {
        return bad(
            "samples",
            o.samples.to_string(),
            &format!("use 2 to {MAX_SAMPLES}"),
        );
    }
    match o.smoothing {
        Smoothing::Gcv => {}
        Smoothing::Lambda(a) if a.is_finite() && a > 0.0 => {}
        Smoothing::Lambda(a) => return bad("smoothing", a.to_string(), "use a finite number > 0"),
        Smoothing::DegreesOfFreedom(df) if df.is_finite() && df > 2.0 => {}
        Smoothing::DegreesOfFreedom(df) => {
            return bad(
                "smoothing",
                df.to_string(),
                "degrees of freedom must be more than 2 (a straight line) and at most the number of points",
            )
        }
    }
    if let Some(m) = o.nodes {
        if !(3..=samir::MAX_NODES).contains(&m) {
            return bad(
                "nodes",
                m.to_string(),
                &format!("use 3 to {}", samir::MAX_NODES),
            );
        }
    }
    if o.iterations == Some(0) {
        return bad("iterations", "0".into(), "use at least 1");
    }
    Ok(())
}

/// The paper's errors of `fitted` against `points`, radians.
pub(crate) fn errors(points: &PointSet, fitted: &PointSet) -> ErrorMetrics {
    let mut sums = ErrorSums::default();
    for (i, (p, c)) in points.iter().zip(fitted.iter()).enumerate() {
        let e = angle_between(p, c);
        if e.is_nan() {
            sums.add(i, f64::INFINITY);
        } else {
            sums.add(i, e);
        }
    }
    sums.metrics()
}

/// The piecewise-geodesic path through `points` at `params` (non-decreasing), evaluated at
/// each of `ts` (clamped to the ends).
pub(crate) fn polyline_at(points: &PointSet, params: &[f64], ts: &[f64]) -> PointSet {
    let dim = points.dim();
    let d = Dynamic(dim);
    let last = params.len() - 1;
    let mut coords = Vec::with_capacity(ts.len() * dim);
    for &t in ts {
        let k = params.partition_point(|&u| u <= t).clamp(1, last) - 1;
        let h = params[k + 1] - params[k];
        let s = if h > 0.0 {
            ((t - params[k]) / h).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let (a, b) = (points.get(k), points.get(k + 1));
        let (w0, w1) = Arc::between(d, a, b).weights(s);
        let start = coords.len();
        coords.extend(a.iter().zip(b).map(|(x, y)| w0 * x + w1 * y));
        crate::sphere::geometry::point::normalize(d, &mut coords[start..]);
    }
    PointSet::from_flat_unchecked(dim, coords)
}

/// A deadline check shared by the iterative methods: the caller's cancellation (an error) and
/// the time budget (a normal stop).
pub(crate) struct Clock {
    start: Instant,
    budget: Option<Duration>,
}

impl Clock {
    pub(crate) fn start(budget: Option<Duration>) -> Clock {
        Clock {
            start: Instant::now(),
            budget,
        }
    }
    /// True once the time budget is spent.
    pub(crate) fn spent(&self) -> bool {
        self.budget.is_some_and(|b| self.start.elapsed() >= b)
    }
}

impl MethodFit {
    /// The fit as the JSON document the front ends write for `method` other than `gls-pia`:
    /// `{"method", "parameters", "fitted_points", "metrics": {"max_error_rad",
    /// "mean_error_rad", "rms_error_rad"}, "iterations", "converged", "free_points",
    /// "curve": {"type": "polyline", "parameters", "points"}}` — the curve as dense samples,
    /// the points at the data parameters, so any error can be recomputed.
    pub fn document(&self) -> serde_json::Value {
        serde_json::json!({
            "method": self.method.name(),
            "parameters": self.parameters,
            "fitted_points": self.fitted.to_rows(),
            "metrics": {
                "max_error_rad": self.metrics.max_error_rad,
                "mean_error_rad": self.metrics.mean_error_rad,
                "rms_error_rad": self.metrics.rms_error_rad,
            },
            "iterations": self.iterations,
            "converged": self.converged,
            "free_points": self.free_points,
            "curve": {
                "type": "polyline",
                "parameters": self.sample_parameters,
                "points": self.samples.to_rows(),
            },
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_polyline_at_parameters_passes_its_vertices_and_follows_its_arcs() {
        let pts =
            PointSet::try_from_rows(&[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]).unwrap();
        let t = [0.0, 0.25, 1.0];
        let at = polyline_at(&pts, &t, &[0.0, 0.125, 0.25, 1.0, 2.0]);
        assert!(angle_between(at.get(0), pts.get(0)) < 1e-15);
        let half = std::f64::consts::FRAC_PI_4;
        assert!(angle_between(at.get(1), &[half.cos(), half.sin(), 0.0]) < 1e-15);
        assert!(angle_between(at.get(2), pts.get(1)) < 1e-15);
        assert!(angle_between(at.get(3), pts.get(2)) < 1e-15);
        assert!(angle_between(at.get(4), pts.get(2)) < 1e-15);
    }

    #[test]
    fn the_document_holds_what_the_errors_are_recomputed_from() {
        let rows: Vec<[f64; 3]> = (0..20)
            .map(|i| {
                let a = 0.1 * i as f64;
                [a.cos() * 0.8, a.sin() * 0.8, 0.6]
            })
            .collect();
        let pts = PointSet::try_from_rows(&rows).unwrap();
        let f = fit_with(
            Method::Bcc,
            &pts,
            None,
            &MethodOptions::default().with_samples(11),
        )
        .unwrap();
        let doc = f.document();
        assert_eq!(doc["method"], "bcc");
        assert_eq!(doc["curve"]["points"].as_array().unwrap().len(), 11);
        let fitted = doc["fitted_points"].as_array().unwrap();
        let max = rows
            .iter()
            .zip(fitted)
            .map(|(p, q)| {
                let q: Vec<f64> = q
                    .as_array()
                    .unwrap()
                    .iter()
                    .map(|x| x.as_f64().unwrap())
                    .collect();
                angle_between(p, &q)
            })
            .fold(0.0, f64::max);
        assert_eq!(doc["metrics"]["max_error_rad"].as_f64().unwrap(), max);
    }
}
