//! Longitude/latitude in degrees <-> unit vectors on S^2, and radians <-> metres on the Earth.
//!
//! Conventions (METHOD.md, "Conventions for errors and the Earth"): lon/lat in degrees, WGS 84
//! order `[lon, lat]` as in RFC 7946; `x = cos(lat) cos(lon)`, `y = cos(lat) sin(lon)`,
//! `z = sin(lat)`; a geodesic angle of `a` radians is `a * 6,371,008.8` metres (the IUGG mean
//! radius). The Earth is treated as a sphere: distances differ from the ellipsoid by up to 0.5 %.

/// IUGG mean Earth radius in metres: metres = radians x this.
pub const EARTH_RADIUS_M: f64 = 6_371_008.8;

/// Geodesic angle in radians to metres on the Earth.
#[inline]
pub fn rad_to_m(angle_rad: f64) -> f64 {
    angle_rad * EARTH_RADIUS_M
}

/// Metres on the Earth to a geodesic angle in radians.
#[inline]
pub fn m_to_rad(distance_m: f64) -> f64 {
    distance_m / EARTH_RADIUS_M
}

/// A position in degrees: longitude in [-180, 180], latitude in [-90, 90].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LonLat {
    /// Longitude, degrees east.
    pub lon_deg: f64,
    /// Latitude, degrees north.
    pub lat_deg: f64,
}

/// Why a pair of numbers is not a position.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum LonLatError {
    /// Longitudes outside [-180, 180] are rejected, not wrapped: a value like 181 usually means
    /// swapped or projected coordinates, and wrapping would hide that.
    #[error("longitude {lon_deg} is outside [-180, 180] (longitudes are not wrapped; is this [lat, lon] or a projected coordinate?)")]
    LongitudeOutOfRange {
        /// The longitude given.
        lon_deg: f64,
    },
    /// Latitudes outside [-90, 90]: no point on the Earth.
    #[error("latitude {lat_deg} is outside [-90, 90] (positions are [longitude, latitude])")]
    LatitudeOutOfRange {
        /// The latitude given.
        lat_deg: f64,
    },
    /// A NaN or infinite coordinate.
    #[error("coordinate is not a finite number")]
    NotFinite,
}

impl LonLat {
    /// Validates the ranges (no wrapping).
    ///
    /// # Errors
    /// Non-finite values, a longitude outside [-180, 180] or a latitude outside [-90, 90].
    pub fn try_new(lon_deg: f64, lat_deg: f64) -> Result<LonLat, LonLatError> {
        if !lon_deg.is_finite() || !lat_deg.is_finite() {
            return Err(LonLatError::NotFinite);
        }
        if !(-180.0..=180.0).contains(&lon_deg) {
            return Err(LonLatError::LongitudeOutOfRange { lon_deg });
        }
        if !(-90.0..=90.0).contains(&lat_deg) {
            return Err(LonLatError::LatitudeOutOfRange { lat_deg });
        }
        Ok(LonLat { lon_deg, lat_deg })
    }

    /// The unit vector of this position.
    #[inline]
    pub fn to_unit(self) -> [f64; 3] {
        lonlat_to_unit(self.lon_deg, self.lat_deg)
    }

    /// The position of a unit vector (see [`unit_to_lonlat`]).
    #[inline]
    pub fn from_unit(v: &[f64]) -> LonLat {
        let (lon_deg, lat_deg) = unit_to_lonlat(v);
        LonLat { lon_deg, lat_deg }
    }
}

/// Unit vector of `(lon, lat)` in degrees. Exact at the poles (`z = ±1`, `x = y = 0`) and at
/// multiples of 90 degrees, where `sin`/`cos` of converted degrees would leave 6e-17 residues.
#[inline]
pub fn lonlat_to_unit(lon_deg: f64, lat_deg: f64) -> [f64; 3] {
    let (slon, clon) = sin_cos_deg(lon_deg);
    let (slat, clat) = sin_cos_deg(lat_deg);
    [clat * clon, clat * slon, slat]
}

/// `(lon, lat)` in degrees of a unit vector (normalised here, so near-unit input is fine).
/// Longitude is in (-180, 180]; at the poles it is 0.
#[inline]
pub fn unit_to_lonlat(v: &[f64]) -> (f64, f64) {
    let (x, y, z) = (v[0], v[1], v[2]);
    let h = x.hypot(y);
    let lat = z.atan2(h).to_degrees();
    let lon = if h == 0.0 {
        0.0
    } else {
        y.atan2(x).to_degrees()
    };
    (lon, lat.clamp(-90.0, 90.0))
}

/// `sin` and `cos` of an angle in degrees, exact at multiples of 90.
#[inline]
fn sin_cos_deg(deg: f64) -> (f64, f64) {
    // `%` is a call to fmod; longitudes and latitudes are under a turn already, and below a
    // turn the multiples of 90 are these four (the same tests, at a fraction of the cost of
    // rounding every control point of a fit).
    let r = if deg.abs() < 360.0 { deg } else { deg % 360.0 };
    if matches!(r.abs(), 0.0 | 90.0 | 180.0 | 270.0) {
        let q = ((r / 90.0) as i64).rem_euclid(4);
        return match q {
            0 => (0.0, 1.0),
            1 => (1.0, 0.0),
            2 => (0.0, -1.0),
            _ => (-1.0, 0.0),
        };
    }
    r.to_radians().sin_cos()
}

/// Rounds `x` to `decimals` decimal places (for output coordinates).
#[inline]
pub fn round_to(x: f64, decimals: u32) -> f64 {
    let scale = 10f64.powi(decimals as i32);
    if !(x * scale).is_finite() {
        return x;
    }
    let r = (x * scale).round() / scale;
    if r == 0.0 {
        0.0 // no "-0" in output
    } else {
        r
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use proptest::prelude::*;

    #[test]
    fn cardinal_points_are_exact() {
        assert_eq!(lonlat_to_unit(0.0, 0.0), [1.0, 0.0, 0.0]);
        assert_eq!(lonlat_to_unit(90.0, 0.0), [0.0, 1.0, 0.0]);
        assert_eq!(lonlat_to_unit(180.0, 0.0), [-1.0, 0.0, 0.0]);
        assert_eq!(lonlat_to_unit(-180.0, 0.0), [-1.0, 0.0, 0.0]);
        assert_eq!(lonlat_to_unit(-90.0, 0.0), [0.0, -1.0, 0.0]);
        assert_eq!(lonlat_to_unit(37.0, 90.0)[2], 1.0);
        assert_eq!(unit_to_lonlat(&[0.0, 0.0, -1.0]), (0.0, -90.0));
    }

    #[test]
    fn ranges_are_checked_not_wrapped() {
        assert!(matches!(
            LonLat::try_new(181.0, 0.0),
            Err(LonLatError::LongitudeOutOfRange { .. })
        ));
        assert!(matches!(
            LonLat::try_new(0.0, 91.0),
            Err(LonLatError::LatitudeOutOfRange { .. })
        ));
        assert!(LonLat::try_new(-180.0, -90.0).is_ok());
    }

    #[test]
    fn metres_use_the_mean_radius() {
        assert_relative_eq!(rad_to_m(1.0), 6_371_008.8);
        // One degree of a great circle is about 111.195 km.
        assert_relative_eq!(rad_to_m(1f64.to_radians()), 111_195.08, epsilon = 0.01);
        assert_relative_eq!(m_to_rad(rad_to_m(0.3)), 0.3);
    }

    #[test]
    fn rounding_drops_negative_zero() {
        assert_eq!(round_to(-0.000_000_01, 7).to_string(), "0");
        assert_eq!(round_to(12.345_678_96, 7), 12.345_679);
    }

    proptest! {
        #[test]
        fn lonlat_round_trips(lon in -180.0f64..=180.0, lat in -89.999f64..=89.999) {
            let v = lonlat_to_unit(lon, lat);
            let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            prop_assert!((n - 1.0).abs() < 1e-15);
            let (lon2, lat2) = unit_to_lonlat(&v);
            prop_assert!((lat2 - lat).abs() < 1e-9);
            // -180 and 180 are the same meridian.
            let dlon = (lon2 - lon).rem_euclid(360.0);
            prop_assert!(dlon.min(360.0 - dlon) < 1e-9, "{} vs {}", lon, lon2);
        }
    }
}
