//! Where a feature's times are, for a fit in time: a property or the 4th coordinate, one array
//! per line of a MultiLineString.

use crate::earth::curve::times::LineTimeInput;
use crate::earth::error::{EarthError, Problem};
use crate::earth::job::Job;
use crate::earth::time::TIME_PROPERTIES;

use serde_json::{Map, Value};

/// Where a feature's times are, for a fit in time.
#[derive(Clone, Debug)]
pub(super) enum FeatureTimes<'a> {
    /// Not a fit in time.
    None,
    /// `properties[name]`, at `pointer`.
    Property {
        value: &'a Value,
        pointer: String,
        name: String,
    },
    /// The 4th coordinate.
    M,
}

/// Escapes a key for a JSON pointer (RFC 6901: `~` as `~0`, `/` as `~1`).
pub(super) fn pointer_key(k: &str) -> String {
    k.replace('~', "~0").replace('/', "~1")
}

/// Finds a feature's times for a fit in time ([`crate::earth::time`]).
pub(super) fn feature_times<'a>(
    feature: &'a Map<String, Value>,
    pointer: &str,
    job: &Job,
) -> Result<FeatureTimes<'a>, EarthError> {
    let Some(source) = &job.time.fit_in_time else {
        return Ok(FeatureTimes::None);
    };
    let props = feature.get("properties").and_then(Value::as_object);
    let found = |name: &str| {
        props
            .and_then(|p| p.get(name))
            .map(|value| FeatureTimes::Property {
                value,
                pointer: format!("{pointer}/properties/{}", pointer_key(name)),
                name: name.to_string(),
            })
    };
    match source {
        crate::earth::TimeSource::Property(name) => found(name).ok_or_else(|| {
            EarthError::new(
                format!("{pointer}/properties"),
                Problem::InvalidTime(format!(
                    "no property {name:?} (time_property) holding this feature's times"
                )),
            )
        }),
        crate::earth::TimeSource::Auto => Ok(TIME_PROPERTIES
            .iter()
            .find_map(|n| found(n))
            .unwrap_or(FeatureTimes::M)),
    }
}

/// The times of line `part` (`None` for a LineString) of a feature in time.
pub(super) fn line_times<'a>(
    times: &FeatureTimes<'a>,
    part: Option<usize>,
) -> Result<Option<LineTimeInput<'a>>, EarthError> {
    match (times, part) {
        (FeatureTimes::None, _) => Ok(None),
        (FeatureTimes::M, _) => Ok(Some(LineTimeInput::M)),
        (
            FeatureTimes::Property {
                value,
                pointer,
                name,
            },
            None,
        ) => Ok(Some(LineTimeInput::Property {
            value,
            pointer: pointer.clone(),
            name: name.clone(),
        })),
        (
            FeatureTimes::Property {
                value,
                pointer,
                name,
            },
            Some(i),
        ) => {
            let v = value.as_array().and_then(|a| a.get(i)).ok_or_else(|| {
                EarthError::new(
                    pointer.clone(),
                    Problem::InvalidTime(format!(
                        "a MultiLineString's times are one array per line ([[t, ...], [t, ...]]): line {i} has none"
                    )),
                )
            })?;
            Ok(Some(LineTimeInput::Property {
                value: v,
                pointer: format!("{pointer}/{i}"),
                name: name.clone(),
            }))
        }
    }
}
