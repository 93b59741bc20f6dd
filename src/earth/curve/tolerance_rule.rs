//! How a tolerance fit's curve is judged and retried, decided once for a line or ring fitted on
//! its own ([`fit_line_to_tolerance`](crate::earth::curve::fitting::fit_line_to_tolerance)) and for an arc of a coverage (`topology=shared`).

use crate::earth::curve::fitting::{polyline_target_rad, rounding_bound_rad, tolerance_target_rad};
use crate::earth::curve::positions::round_m;
use crate::earth::lonlat::{m_to_rad, rad_to_m};
use crate::sphere::compress::tolerance::MAX_LENGTH_RATIO;

/// A tolerance in metres that a curve as returned (control points rounded to `precision`,
/// rings closed) must meet: its max error at the positions and its two-way distance from the
/// line within the tolerance (also once rounded to millimetres, as reported), and the curve at
/// most [`MAX_LENGTH_RATIO`] times as long as the line (plus the tolerance), as the fitter of
/// [`crate::sphere::compress::tolerance`] asks of itself.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ToleranceRule {
    /// The tolerance, metres.
    pub tolerance_m: f64,
    /// The tolerance, radians.
    pub tol_rad: f64,
    /// Decimals of a degree the control points are rounded to.
    pub precision: u32,
    /// Decimal steps in one step of the grid they are rounded to
    /// ([`crate::earth::OutputOptions::grid_multiple`]): 1 unless a coverage's TopoJSON grid.
    pub grid_multiple: u32,
    /// A coverage's first fit of an arc: a polyline aims at [`Self::snap_target_rad`] first.
    /// Not for arcs refitted tighter to part from a neighbour (aiming nearer the tolerance
    /// makes them stray towards it again).
    pub snap_first: bool,
}

impl ToleranceRule {
    /// The rule for `tolerance_m` at `precision`.
    pub fn new(tolerance_m: f64, precision: u32) -> ToleranceRule {
        ToleranceRule {
            tolerance_m,
            tol_rad: m_to_rad(tolerance_m),
            precision,
            grid_multiple: 1,
            snap_first: false,
        }
    }

    /// The rule with [`Self::snap_first`] set to `snap_first`.
    pub fn with_snap_first(self, snap_first: bool) -> ToleranceRule {
        ToleranceRule { snap_first, ..self }
    }

    /// The rule with positions rounded to a grid of `multiple` decimal steps.
    pub fn with_grid_multiple(self, multiple: u32) -> ToleranceRule {
        ToleranceRule {
            grid_multiple: multiple.max(1),
            ..self
        }
    }

    /// How far rounding to the grid moves a position at most, radians.
    pub fn rounding_bound_rad(&self) -> f64 {
        f64::from(self.grid_multiple) * rounding_bound_rad(self.precision)
    }

    /// What the fitter aims at first: below the tolerance by the rounding of the control
    /// points and by the dense output's margin, where that leaves room.
    pub fn first_target_rad(&self) -> f64 {
        tolerance_target_rad(self.tol_rad, self.rounding_bound_rad())
    }

    /// What a polyline may aim at instead (below the tolerance by its vertices' rounding
    /// only: it is written as its rounded vertices, with no sampling margin); curves of degree >= 2
    /// then keep the difference ([`crate::sphere::ToleranceOptions::smooth_margin_rad`]) and
    /// aim at [`Self::first_target_rad`] as before.
    pub fn polyline_target_rad(&self) -> f64 {
        polyline_target_rad(self.tol_rad, self.rounding_bound_rad())
    }

    /// What a coverage's polyline aims at first (`topology=shared`): below the tolerance by
    /// [`SNAP_SHARE_OF_ROUNDING`] of its vertices' rounding bound, where
    /// [`Self::polyline_target_rad`] takes all of it. Rounding moves few vertices by nearly
    /// the bound, and not all of those towards the line's far side, so most arcs fitted to it
    /// still meet the tolerance as written; the caller measures the rounded arc and fits it
    /// again at [`Self::polyline_target_rad`] when it does not. Only above that target (a
    /// tolerance over three rounding bounds).
    pub fn snap_target_rad(&self) -> f64 {
        let bound = self.rounding_bound_rad();
        if self.tol_rad > 3.0 * bound {
            self.tol_rad - SNAP_SHARE_OF_ROUNDING * bound
        } else {
            self.polyline_target_rad()
        }
    }

    /// Whether a curve as returned meets the tolerance: `worst_rad` is the larger of its max
    /// error at the positions and its two-way distance from the line, `curve_length_rad` and
    /// `line_length_rad` the lengths of the curve and of the line.
    pub fn met(&self, worst_rad: f64, curve_length_rad: f64, line_length_rad: f64) -> bool {
        worst_rad <= self.tol_rad
            && round_m(rad_to_m(worst_rad)) <= self.tolerance_m
            && curve_length_rad <= MAX_LENGTH_RATIO * line_length_rad + self.tol_rad
    }

    /// The one retry: when the fitter met its `target_rad` (`fitter_met`) but rounding (or
    /// closing a ring) took the curve as returned over the tolerance (`worst_rad`) on the
    /// first `attempt`, the fit is run again aiming lower by twice the excess and the rounding
    /// bound, unless that leaves less than a quarter of the tolerance.
    pub fn retry_target_rad(
        &self,
        target_rad: f64,
        worst_rad: f64,
        fitter_met: bool,
        attempt: usize,
    ) -> Option<f64> {
        if !(fitter_met && attempt == 0 && worst_rad > self.tol_rad) {
            return None;
        }
        let lower = target_rad - 2.0 * (worst_rad - self.tol_rad) - self.rounding_bound_rad();
        (lower > 0.25 * self.tol_rad).then_some(lower)
    }
}

/// The share of the rounding bound a coverage's polyline keeps below the tolerance on its
/// first fit ([`ToleranceRule::snap_target_rad`]). World-atlas countries at 1 km on the
/// TopoJSON grid of 0.004 degrees (rounding bound 314 m), gzipped bytes of 50m and 10m and the
/// 10m run's CPU against no first fit: 0.3: 152.5 KB, 405.7 KB, +31 %; 0.45: 153.1 KB,
/// 416.9 KB, +27 %; 0.5: 153.7 KB, 417.2 KB, +23 %; 0.6: 155.4 KB, 423.6 KB, +14 %; none:
/// 163.4 KB. Nearer the tolerance more arcs miss as written and are fitted twice; 0.6 keeps
/// the coverage run's CPU within a fifth of what it was.
pub const SNAP_SHARE_OF_ROUNDING: f64 = 0.6;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn met_needs_the_distance_its_millimetres_and_the_length_within_the_tolerance() {
        let rule = ToleranceRule::new(100.0, 7);
        let m = |x: f64| m_to_rad(x);
        assert!(rule.met(m(99.0), 1.0, 1.0));
        assert!(!rule.met(m(100.01), 1.0, 1.0));
        // A sub-millimetre tolerance: within it, but not once rounded to the millimetre.
        let fine = ToleranceRule::new(0.0007, 7);
        assert!(!fine.met(m(0.0006), 1.0, 1.0));
        assert!(fine.met(m(0.0004), 1.0, 1.0));
        // A curve much longer than its line does not meet it, however close.
        assert!(!rule.met(m(1.0), 1.3, 1.0));
        assert!(rule.met(m(1.0), 1.2, 1.0));
    }

    #[test]
    fn one_retry_aims_lower_by_the_excess() {
        let rule = ToleranceRule::new(100.0, 7);
        let t = rule.first_target_rad();
        assert!(t < rule.tol_rad);
        let over = 1.01 * rule.tol_rad;
        let lower = rule.retry_target_rad(t, over, true, 0).expect("a retry");
        assert!(lower < t - 2.0 * (over - rule.tol_rad) + 1e-18);
        // Only once, only when the fitter met its target, only when over the tolerance.
        assert_eq!(rule.retry_target_rad(t, over, true, 1), None);
        assert_eq!(rule.retry_target_rad(t, over, false, 0), None);
        assert_eq!(rule.retry_target_rad(t, 0.99 * rule.tol_rad, true, 0), None);
        // Not below a quarter of the tolerance.
        assert_eq!(rule.retry_target_rad(t, 1.5 * rule.tol_rad, true, 0), None);
    }
}
