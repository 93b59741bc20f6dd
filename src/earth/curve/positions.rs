//! The positions of one line or ring: parsed and checked (numbers, ranges, rings closed),
//! repeats dropped ([`DistinctPositions`]), and math-core errors on them mapped back to the
//! input position (`sphere_error`).

use crate::earth::curve::times::{timed_line, LineTimeInput, Timed};
use crate::earth::error::{EarthError, Problem};
use crate::earth::lonlat::{round_to, LonLat};
use crate::sphere::geometry::point::{angle_between, PointSet, ANTIPODAL_MARGIN_RAD};
use crate::sphere::{InputSite, SphereError};
use serde_json::Value;

/// Consecutive positions closer than this (radians; 0.6 mm on the Earth) are repeats: far below
/// the 1.1 cm resolution of 7-decimal coordinates, far above rounding noise.
pub const REPEAT_ANGLE_RAD: f64 = 1e-10;

/// Output altitudes are rounded to millimetres.
pub(super) const ALTITUDE_DECIMALS: u32 = 3;

/// Reported metres are rounded to millimetres.
pub(super) fn round_m(x: f64) -> f64 {
    round_to(x, 3)
}

/// The positions of one line as unit vectors, with altitudes when every position has one.
#[derive(Clone, Debug, PartialEq)]
pub struct LinePositions {
    /// The positions as unit vectors.
    pub points: Vec<[f64; 3]>,
    /// One altitude per position, when every position has one.
    pub alts: Option<Vec<f64>>,
    /// The 4th number of every position (a time), when read with `allow_m` and every
    /// position has one.
    pub m: Option<Vec<f64>>,
}

/// Reads `[[lon, lat(, alt)], ...]`, checking types, ranges and that either all positions or
/// none have an altitude.
///
/// # Errors
/// [`Problem::InvalidGeoJson`] when `v` is not an array; [`Problem::InvalidCoordinate`] at the
/// offending position or number.
pub fn parse_positions(v: &Value, pointer: &str) -> Result<LinePositions, EarthError> {
    parse_positions_with(v, pointer, false)
}

/// As [`parse_positions`]; with `allow_m`, positions may also be `[lon, lat, alt, t]` (all of
/// a line alike), the 4th number kept in [`LinePositions::m`].
///
/// # Errors
/// As [`parse_positions`].
pub fn parse_positions_with(
    v: &Value,
    pointer: &str,
    allow_m: bool,
) -> Result<LinePositions, EarthError> {
    let max_len = if allow_m { 4 } else { 3 };
    let arr = v.as_array().ok_or_else(|| {
        EarthError::new(
            pointer,
            Problem::InvalidGeoJson("expected an array of positions [longitude, latitude]".into()),
        )
    })?;
    let mut points = Vec::with_capacity(arr.len());
    let mut alts = Vec::new();
    let mut ms = Vec::new();
    let mut with_alt: Option<usize> = None;
    for (i, pos) in arr.iter().enumerate() {
        let bad = |ptr: String, msg: String| EarthError::new(ptr, Problem::InvalidCoordinate(msg));
        let nums = pos.as_array().ok_or_else(|| {
            bad(
                format!("{pointer}/{i}"),
                "a position is an array [longitude, latitude] or [longitude, latitude, altitude]"
                    .into(),
            )
        })?;
        if nums.len() < 2 || nums.len() > max_len {
            return Err(bad(
                format!("{pointer}/{i}"),
                if allow_m {
                    format!(
                        "a position has 2 to 4 numbers ([longitude, latitude(, altitude(, time))]), this one has {}",
                        nums.len()
                    )
                } else {
                    format!(
                        "a position has 2 or 3 numbers ([longitude, latitude(, altitude)]), this one has {}{}",
                        nums.len(),
                        if nums.len() == 4 {
                            " (a 4th number is read as a time only with parameterization time)"
                        } else {
                            ""
                        }
                    )
                },
            ));
        }
        let mut xs = [0.0; 4];
        for (k, x) in nums.iter().enumerate() {
            xs[k] = x.as_f64().ok_or_else(|| {
                bad(
                    format!("{pointer}/{i}/{k}"),
                    format!("expected a number, got {}", json_kind(x)),
                )
            })?;
        }
        match with_alt {
            None => with_alt = Some(nums.len()),
            Some(w) if w != nums.len() => {
                return Err(bad(
                    format!("{pointer}/{i}"),
                    format!(
                        "this position has {} numbers but the first has {w}: give an altitude{} for every position of a line or for none",
                        nums.len(),
                        if allow_m { " (and a time)" } else { "" }
                    ),
                ));
            }
            Some(_) => {}
        }
        let has_alt = nums.len() >= 3;
        let ll = LonLat::try_new(xs[0], xs[1]).map_err(|e| {
            let k = match e {
                crate::earth::lonlat::LonLatError::LatitudeOutOfRange { .. } => 1,
                _ => 0,
            };
            bad(format!("{pointer}/{i}/{k}"), e.to_string())
        })?;
        points.push(ll.to_unit());
        if has_alt {
            alts.push(xs[2]);
        }
        if nums.len() == 4 {
            ms.push(xs[3]);
        }
    }
    Ok(LinePositions {
        points,
        alts: (with_alt >= Some(3)).then_some(alts),
        m: (with_alt == Some(4)).then_some(ms),
    })
}

/// The JSON type of a value, for messages.
pub(crate) fn json_kind(v: &Value) -> &'static str {
    match v {
        Value::Null => "null",
        Value::Bool(_) => "a boolean",
        Value::Number(_) => "a number",
        Value::String(_) => "a string",
        Value::Array(_) => "an array",
        Value::Object(_) => "an object",
    }
}

/// A line with repeated consecutive positions dropped.
#[derive(Clone, Debug)]
pub struct DistinctPositions {
    /// The kept positions.
    pub points: Vec<[f64; 3]>,
    /// Index of each kept position in the input.
    pub input_index: Vec<usize>,
    /// How many input positions each kept one stands for (1 + its repeats).
    pub multiplicity: Vec<usize>,
    /// Altitude of each kept position (that of its first copy; zeros without altitudes).
    pub alts: Vec<f64>,
}

impl DistinctPositions {
    /// Drops repeats (within [`REPEAT_ANGLE_RAD`] of the previous kept position).
    pub fn from_line(line: &LinePositions) -> DistinctPositions {
        Self::dropping(line, |_, last, p| {
            angle_between(last, p) <= REPEAT_ANGLE_RAD
        })
    }

    /// Drops the positions flagged in `duplicate` (records repeated exactly, time and
    /// position), keeping every other one, even where the position repeats at a later time.
    pub fn from_line_timed(line: &LinePositions, duplicate: &[bool]) -> DistinctPositions {
        Self::dropping(line, |i, _, _| duplicate[i])
    }

    /// Keeps position 0 and every later position `i` for which `repeat(i, last kept, p)` is
    /// false; a dropped one counts towards the multiplicity of the last kept one.
    fn dropping(
        line: &LinePositions,
        repeat: impl Fn(usize, &[f64; 3], &[f64; 3]) -> bool,
    ) -> DistinctPositions {
        let mut d = DistinctPositions {
            points: Vec::with_capacity(line.points.len()),
            input_index: Vec::with_capacity(line.points.len()),
            multiplicity: Vec::with_capacity(line.points.len()),
            alts: Vec::with_capacity(line.points.len()),
        };
        for (i, p) in line.points.iter().enumerate() {
            if let Some(last) = d.points.last() {
                if repeat(i, last, p) {
                    *d.multiplicity.last_mut().expect("non-empty") += 1;
                    continue;
                }
            }
            d.points.push(*p);
            d.input_index.push(i);
            d.multiplicity.push(1);
            d.alts.push(line.alts.as_ref().map_or(0.0, |a| a[i]));
        }
        d
    }

    /// Number of distinct positions.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// True when there are none.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    pub(crate) fn point_set(&self) -> PointSet {
        PointSet::try_from_rows(&self.points).expect("lon/lat positions are unit vectors")
    }

    /// Errors unless there are at least 2 distinct positions and no antipodal neighbours.
    pub(super) fn check_curve(&self, pointer: &str) -> Result<(), EarthError> {
        if self.len() < 2 {
            return Err(EarthError::new(
                pointer,
                Problem::TooFewPoints {
                    distinct: self.len(),
                    need: 2,
                },
            ));
        }
        for i in 1..self.len() {
            let a = angle_between(&self.points[i - 1], &self.points[i]);
            if a >= std::f64::consts::PI - ANTIPODAL_MARGIN_RAD {
                return Err(EarthError::new(
                    format!("{pointer}/{}", self.input_index[i]),
                    Problem::Antipodal {
                        angle_deg: a.to_degrees(),
                    },
                ));
            }
        }
        Ok(())
    }
}

/// Checks that a ring is closed (last position = first) and has at least 4 positions.
pub(super) fn check_ring(line: &LinePositions, pointer: &str) -> Result<(), EarthError> {
    let n = line.points.len();
    if n < 4 {
        return Err(EarthError::new(
            pointer,
            Problem::InvalidRing(format!(
                "a Polygon ring needs at least 4 positions (the last repeating the first), got {n}"
            )),
        ));
    }
    if angle_between(&line.points[0], &line.points[n - 1]) > REPEAT_ANGLE_RAD {
        return Err(EarthError::new(
            format!("{pointer}/{}", n - 1),
            Problem::InvalidRing(
                "a Polygon ring must end where it starts: the last position differs from the first"
                    .into(),
            ),
        ));
    }
    Ok(())
}

/// The start every curve operation shares: parse the positions, check a ring is closed, drop
/// repeated consecutive positions and make sure enough distinct ones remain. With `time`, the
/// line's times are read and checked, only duplicate records (same time and position) are
/// dropped, and the line is never closed.
pub(crate) fn prepare_line(
    coords: &Value,
    pointer: &str,
    closed: bool,
    time: Option<&LineTimeInput<'_>>,
) -> Result<(LinePositions, DistinctPositions, Option<Timed>), EarthError> {
    let line = parse_positions_with(coords, pointer, matches!(time, Some(LineTimeInput::M)))?;
    if let Some(input) = time {
        // Checked by timed_line (before its times are mapped).
        let (distinct, timed) = timed_line(&line, pointer, input)?;
        return Ok((line, distinct, Some(timed)));
    }
    if closed {
        check_ring(&line, pointer)?;
    }
    let distinct = DistinctPositions::from_line(&line);
    distinct.check_curve(pointer)?;
    Ok((line, distinct, None))
}

/// A LineString whose last position repeats its first (within [`REPEAT_ANGLE_RAD`]) with at
/// least 4 distinct positions is a closed curve, like a Polygon ring.
pub(super) fn is_closed_line(d: &DistinctPositions) -> bool {
    let n = d.len();
    n >= 4 && angle_between(&d.points[0], &d.points[n - 1]) <= REPEAT_ANGLE_RAD
}

/// Whether a fit closes the curve: asked for (a ring) or a line that ends where it starts, and
/// never in time (a track that comes back is not a loop).
pub(crate) fn fits_closed(closed: bool, d: &DistinctPositions, timed: Option<&Timed>) -> bool {
    timed.is_none() && (closed || is_closed_line(d))
}

/// The median distance between consecutive distinct positions (radians).
pub(super) fn median_step_rad(d: &DistinctPositions) -> f64 {
    let mut steps: Vec<f64> = d
        .points
        .windows(2)
        .map(|w| angle_between(&w[0], &w[1]))
        .collect();
    if steps.is_empty() {
        return 0.0;
    }
    let k = steps.len() / 2;
    *steps.select_nth_unstable_by(k, f64::total_cmp).1
}

/// Maps a math-core error on distinct positions to a GeoJSON error: at the input position
/// when it names a point ([`SphereError::site`]), else at the line (`pointer`).
pub(crate) fn sphere_error(e: SphereError, pointer: &str, input_index: &[usize]) -> EarthError {
    let at = match e.site() {
        InputSite::Point { index, .. } => format!(
            "{pointer}/{}",
            input_index.get(index).copied().unwrap_or(index)
        ),
        _ => pointer.to_string(),
    };
    let problem = match e {
        SphereError::Antipodal { angle_rad, .. } => Problem::Antipodal {
            angle_deg: angle_rad.to_degrees(),
        },
        SphereError::TooFewPoints { got, need } => Problem::TooFewPoints {
            distinct: got,
            need,
        },
        SphereError::AllPointsEqual { count } => Problem::TooFewPoints {
            distinct: count.min(1),
            need: 2,
        },
        SphereError::NotInterpolated { .. } | SphereError::DegenerateArc { .. } => {
            Problem::Interpolation(e)
        }
        other => Problem::Fit(other),
    };
    EarthError::new(at, problem)
}
