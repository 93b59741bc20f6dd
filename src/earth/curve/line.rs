//! What the curve functions take: the line (or stored curve) and where it sits ([`LineRef`]),
//! how its output is made and bounded ([`OutputSpec`]), and the errors of its positions
//! summed for the report (`ErrorSums`).

use crate::earth::curve::output::CurveReport;
use crate::earth::job::{Limits, OutputOptions};
use crate::earth::lonlat::rad_to_m;
use serde_json::{Map, Value};

/// One line or ring of a geometry, or a stored curve document, and where it sits.
#[derive(Clone, Copy, Debug)]
pub struct LineRef<'a> {
    /// The GeoJSON coordinates array (for evaluation, the stored curve document).
    pub value: &'a Value,
    /// Its JSON pointer in the input (`/features/3/geometry/coordinates/0`).
    pub pointer: &'a str,
    /// Its place in its geometry ([`CurveReport::path`]).
    pub path: &'a [usize],
    /// A ring: made as a closed curve.
    pub closed: bool,
}

/// How output lines are made, and the limits that bound them.
#[derive(Clone, Copy, Debug)]
pub struct OutputSpec<'a> {
    /// Sampling and precision.
    pub output: &'a OutputOptions,
    /// Bounds checked before the work they bound.
    pub limits: &'a Limits,
}

/// The errors of a line's positions from its curve: the largest, their sum and the sum of
/// their squares, radians, each distinct position counted once per input copy.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct ErrorSums {
    pub(super) max_rad: f64,
    pub(super) sum_rad: f64,
    pub(super) sq_rad: f64,
}

impl ErrorSums {
    /// Sums `(error, copies)` of each distinct position.
    pub(super) fn of(errors: impl IntoIterator<Item = (f64, usize)>) -> ErrorSums {
        let mut s = ErrorSums::default();
        for (e, k) in errors {
            s.max_rad = s.max_rad.max(e);
            s.sum_rad += e * k as f64;
            s.sq_rad += e * e * k as f64;
        }
        s
    }
}

impl CurveReport {
    /// The report of `line` with these `fields` and the errors `e` of its `input_points`
    /// positions; no spline, and the output and stored counts zero until set.
    pub(super) fn of_line(
        line: LineRef<'_>,
        fields: Map<String, Value>,
        input_points: usize,
        e: ErrorSums,
    ) -> CurveReport {
        CurveReport {
            path: line.path.to_vec(),
            closed: line.closed,
            fields,
            spline: None,
            input_points,
            output_points: 0,
            stored_numbers: 0,
            max_error_m: rad_to_m(e.max_rad),
            error_sum_m: rad_to_m(e.sum_rad),
            error_sq_sum_m2: rad_to_m(rad_to_m(e.sq_rad)),
        }
    }
}
