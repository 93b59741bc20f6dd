//! The grid a coverage's TopoJSON is written on: a multiple of the output's decimal step.
//!
//! TopoJSON stores an arc as integer steps of its `transform` grid, delta-encoded, so its bytes
//! grow with the digits of those steps, not with decimals. A tolerance picks the decimals
//! ([`super::precision_for_tolerance`]: rounding within a tenth of it); a coverage written as
//! TopoJSON then takes a step of 2, 3, ... of those decimals, as coarse as keeps rounding
//! under [`TOPOJSON_GRID_SHARE_OF_TOLERANCE`] of the tolerance. Every arc is fitted below the
//! tolerance by that rounding (or fitted nearer and kept only when it meets the tolerance as
//! rounded, [`crate::earth::curve::ToleranceRule::snap_target_rad`]) and measured as written on
//! the grid, so the two-way bound holds as before; the steps are fewer digits.
//!
//! Measured on the world-atlas 50m countries at 1 km (`scripts/bytes_bench.sh`, gzipped
//! TopoJSON, with the first fit nearer the tolerance): grid steps of 0.001, 0.002, 0.003 and
//! 0.004 degrees wrote 181.8, 169.3, 160.9 and 156.6 KB, their positions 47.9k, 49.0k, 49.9k and
//! 51.3k (more vertices, each fewer bytes). 0.005 degrees (rounding 393 m) is over a third of
//! the tolerance, where the fit no longer aims below it by the rounding.

/// The share of a tolerance that rounding a coverage's TopoJSON to its grid stays under (see
/// the module docs): a third, the most for which the fit still aims below the tolerance by
/// the rounding (`polyline_target_rad`). With 1 km, 4
/// steps of 0.001 degree (rounding moves a position by at most 314 m).
pub const TOPOJSON_GRID_SHARE_OF_TOLERANCE: f64 = 1.0 / 3.0;

/// Most decimal steps in one grid step: beyond, the next coarser decimal would do.
const MAX_GRID_MULTIPLE: u32 = 9;

/// The most decimal steps (of `precision` decimals of a degree) a coverage's TopoJSON grid step
/// may hold at `tolerance_m`: rounding to it moves a position by less than
/// [`TOPOJSON_GRID_SHARE_OF_TOLERANCE`] of the tolerance, and the step divides 90 degrees, so
/// the grid anchored at TopoJSON's translate `[-180, -90]` is the one anchored at 0 (a
/// longitude of ±180 or a latitude of ±90 is on it). At least 1.
pub fn topojson_grid_multiple(tolerance_m: f64, precision: u32) -> u32 {
    let allowed = TOPOJSON_GRID_SHARE_OF_TOLERANCE * crate::earth::lonlat::m_to_rad(tolerance_m);
    let decimal = crate::earth::curve::fitting::rounding_bound_rad(precision);
    let steps_in_90 =
        |m: u32| precision >= 1 && (90 * 10u64.pow(precision.min(15))) % u64::from(m) == 0;
    (1..=MAX_GRID_MULTIPLE)
        .rev()
        .find(|&m| m == 1 || (steps_in_90(m) && f64::from(m) * decimal < allowed))
        .unwrap_or(1)
}

/// `x` degrees rounded to the grid of `multiple` steps of `precision` decimals (anchored at
/// 0): with `multiple` 1, [`crate::earth::lonlat::round_to`] exactly.
pub fn round_to_grid(x: f64, precision: u32, multiple: u32) -> f64 {
    if multiple <= 1 {
        return crate::earth::lonlat::round_to(x, precision);
    }
    let scale = 10f64.powi(precision as i32);
    if !(x * scale).is_finite() {
        return x;
    }
    let m = f64::from(multiple);
    let r = ((x * scale) / m).round() * m / scale;
    if r == 0.0 {
        0.0
    } else {
        r
    }
}

/// The two grid values around `x` degrees (the grid of [`round_to_grid`]): the highest at or
/// below it and the next one up, written as [`round_to_grid`] writes them.
pub fn grid_neighbours(x: f64, precision: u32, multiple: u32) -> [f64; 2] {
    let scale = 10f64.powi(precision as i32);
    let m = f64::from(multiple.max(1));
    let k = ((x * scale) / m).floor();
    let at = |k: f64| {
        let r = k * m / scale;
        if r == 0.0 {
            0.0
        } else {
            r
        }
    };
    [at(k), at(k + 1.0)]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_kilometre_gets_four_thousandths_and_fine_tolerances_none() {
        // 3 decimals round within 78.6 m; four steps (314 m) are under a third of 1 km, five
        // (393 m) are not.
        assert_eq!(topojson_grid_multiple(1000.0, 3), 4);
        assert_eq!(topojson_grid_multiple(1200.0, 3), 5);
        // At 7 decimals (1.1 cm) and 1 cm nothing coarser is allowed.
        assert_eq!(topojson_grid_multiple(0.01, 7), 1);
        // 7 steps do not divide 90 degrees: 8 or 6 are taken instead.
        let m = topojson_grid_multiple(2500.0, 3);
        assert!(m != 7 && (90_000 % m) == 0, "{m}");
    }

    #[test]
    fn rounding_to_a_grid_lands_on_its_multiples() {
        assert_eq!(round_to_grid(12.3456, 3, 1), 12.346);
        assert_eq!(round_to_grid(12.3456, 3, 3), 12.345);
        assert_eq!(round_to_grid(-12.3471, 3, 3), -12.348);
        assert_eq!(round_to_grid(-0.0001, 3, 3), 0.0);
        assert_eq!(round_to_grid(180.0, 3, 3), 180.0);
        assert_eq!(round_to_grid(-89.9999, 3, 3), -90.0);
    }

    #[test]
    fn grid_neighbours_bracket_a_value_and_hold_its_rounding() {
        for x in [12.3456, -12.3471, 0.0004, -0.0004, 179.9991] {
            let [lo, hi] = grid_neighbours(x, 3, 4);
            assert!(lo <= x && x < hi, "{x}: {lo} {hi}");
            assert!(round_to_grid(x, 3, 4) == lo || round_to_grid(x, 3, 4) == hi);
            assert_eq!(round_to_grid(lo, 3, 4), lo);
            assert_eq!(round_to_grid(hi, 3, 4), hi);
        }
    }
}
