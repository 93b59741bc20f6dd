//! The times of a line fitted in time: read from the input, checked, and made into curve
//! parameters and the time map.

use crate::earth::curve::positions::{DistinctPositions, LinePositions, REPEAT_ANGLE_RAD};
use crate::earth::error::{EarthError, Problem};
use crate::earth::time::{
    check_times, times_from_array, LineTimes, TimeFormat, TimeMap, TimeOrigin,
};
use crate::sphere::geometry::point::angle_between;
use serde_json::Value;

/// Where one line's times are, for a fit in time.
#[derive(Clone, Debug)]
pub enum LineTimeInput<'a> {
    /// This line's array in the property `name`, found at `pointer`.
    Property {
        /// The array (one time per position).
        value: &'a Value,
        /// Its JSON pointer.
        pointer: String,
        /// The property's name.
        name: String,
    },
    /// The 4th number of each position.
    M,
}

/// A line's times, checked, for a fit in time.
#[derive(Clone, Debug)]
pub struct Timed {
    /// Times <-> curve parameter.
    pub map: TimeMap,
    /// Where the times came from (and go to in the output).
    pub origin: TimeOrigin,
    /// The curve parameter of each distinct position: its time mapped to [0, 1].
    pub params: Vec<f64>,
}

/// The dense output's times.
#[derive(Clone, Debug)]
pub struct DenseTimes {
    /// Unix seconds of each dense point.
    pub unix_s: Vec<f64>,
    /// How to write them.
    pub format: TimeFormat,
    /// Where to write them.
    pub origin: TimeOrigin,
}

/// Reads and checks a line's times ([`crate::earth::time`]) and drops duplicate records.
pub(super) fn timed_line(
    line: &LinePositions,
    pointer: &str,
    input: &LineTimeInput<'_>,
) -> Result<(DistinctPositions, Timed), EarthError> {
    let times = match input {
        LineTimeInput::Property {
            value,
            pointer: tp,
            name,
        } => times_from_array(
            value,
            tp,
            line.points.len(),
            TimeOrigin::Property(name.clone()),
        )?,
        LineTimeInput::M => LineTimes {
            unix_s: line.m.clone().ok_or_else(|| {
                EarthError::new(
                    pointer,
                    Problem::InvalidTime(format!(
                        "no times for this line: the feature's properties have none of {} and its positions no 4th number [lon, lat, alt, time]; name the property with time_property",
                        crate::earth::time::TIME_PROPERTIES.join(", ")
                    )),
                )
            })?,
            format: TimeFormat::UnixS,
            origin: TimeOrigin::M,
            pointer: pointer.to_string(),
        },
    };
    let duplicate = check_times(&times, |i| {
        angle_between(&line.points[i - 1], &line.points[i]) <= REPEAT_ANGLE_RAD
    })?;
    let distinct = DistinctPositions::from_line_timed(line, &duplicate);
    distinct.check_curve(pointer)?;
    let kept: Vec<f64> = distinct
        .input_index
        .iter()
        .map(|&i| times.unix_s[i])
        .collect();
    let map = TimeMap {
        start_unix_s: kept[0],
        end_unix_s: kept[kept.len() - 1],
        format: times.format,
    };
    let mut params: Vec<f64> = kept.iter().map(|&t| map.param(t)).collect();
    let last = params.len() - 1;
    params[last] = 1.0;
    Ok((
        distinct,
        Timed {
            map,
            origin: times.origin,
            params,
        },
    ))
}
