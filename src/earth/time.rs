//! Times of a track: read from a feature's properties or the 4th coordinate, checked, mapped to
//! the curve's parameter and written back in the convention they came in.
//!
//! # Where times come from ([`TimeSource`])
//! * A per-position array in the feature's `properties`: `coordTimes` (RFC 3339 strings, as
//!   togeojson and GPX converters write it), `times` or `timestamps` (unix seconds, or RFC 3339
//!   strings), or any property named with `time_property`. For a MultiLineString the property
//!   holds one array per line (`[[t, ...], [t, ...]]`), as togeojson writes it.
//! * The 4th number of each position (`[lon, lat, alt, t]`, the "M" value), unix seconds.
//!
//! Without a name, the first of `coordTimes`, `times`, `timestamps` present is used, and then
//! the 4th coordinate when the positions have one.
//!
//! # What is checked ([`check_times`])
//! One time per position (the array's length is the line's), each a finite number or an RFC
//! 3339 string with an offset (`Z` or `+01:00`), all of one kind per line, and strictly
//! increasing. A repeated time is accepted only when the position repeats too (a record written
//! twice: the copy is dropped); the same time at a different position, or a time earlier than
//! the one before, is an error pointing at the later time.
//!
//! # The mapping to the curve ([`TimeMap`])
//! A track's times `t_0 < ... < t_n` are mapped affinely to the curve's parameter
//! `u = (t - t_0) / (t_n - t_0)` on `[0, 1]`; `properties.fit.time` stores `start` and `end`
//! (and the convention), so the spline can be evaluated at a time.

use crate::earth::error::{EarthError, Problem};
use crate::sphere::curve::bspline::SphericalBSpline;
use serde_json::{json, Map, Value};

/// Property names searched, in order, when no `time_property` is given.
pub const TIME_PROPERTIES: [&str; 3] = ["coordTimes", "times", "timestamps"];

/// Where a fit in time reads its times.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub enum TimeSource {
    /// The first of [`TIME_PROPERTIES`] present, then the 4th coordinate.
    #[default]
    Auto,
    /// This property of the feature.
    Property(String),
}

/// How the input wrote its times; output times are written the same way.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TimeFormat {
    /// RFC 3339 strings (`"2010-10-03T09:36:30Z"`).
    Rfc3339,
    /// Numbers of seconds since 1970-01-01T00:00:00Z.
    UnixS,
}

impl TimeFormat {
    /// The name written in `properties.fit.time.format`.
    pub fn name(self) -> &'static str {
        match self {
            TimeFormat::Rfc3339 => "rfc3339",
            TimeFormat::UnixS => "unix_s",
        }
    }

    /// Reads a name written by [`TimeFormat::name`].
    pub fn from_name(s: &str) -> Option<TimeFormat> {
        match s {
            "rfc3339" => Some(TimeFormat::Rfc3339),
            "unix_s" => Some(TimeFormat::UnixS),
            _ => None,
        }
    }

    /// A unix time in this format: an RFC 3339 string (UTC, fractional seconds only when
    /// there are any, to the nanosecond) or the number itself.
    pub fn write(self, unix_s: f64) -> Value {
        match self {
            TimeFormat::UnixS => json!(round_time(unix_s)),
            TimeFormat::Rfc3339 => match timestamp_of(unix_s) {
                Some(ts) => Value::String(ts.to_string()),
                // Outside the years -9999..=9999 no RFC 3339 string exists: the number then.
                None => json!(unix_s),
            },
        }
    }
}

/// Output times are rounded to microseconds: far below GPS clocks, and unix seconds of this era
/// carry about 0.2 microseconds of f64 resolution anyway.
fn round_time(t: f64) -> f64 {
    let r = (t * 1e6).round() / 1e6;
    if r.is_finite() {
        r
    } else {
        t
    }
}

fn timestamp_of(unix_s: f64) -> Option<jiff::Timestamp> {
    if !unix_s.is_finite() {
        return None;
    }
    let micros = (unix_s * 1e6).round();
    if micros.abs() > 9.0e18 {
        return None;
    }
    let micros = micros as i64;
    let secs = micros.div_euclid(1_000_000);
    let nanos = (micros.rem_euclid(1_000_000) * 1000) as i32;
    jiff::Timestamp::new(secs, nanos).ok()
}

/// Where a track's times sit: the property (for output) or the 4th coordinate.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum TimeOrigin {
    /// `properties[name]`.
    Property(String),
    /// The 4th number of each position.
    M,
}

impl TimeOrigin {
    /// The name written in `properties.fit.time.source` (`"M"` for the 4th coordinate).
    pub fn name(&self) -> &str {
        match self {
            TimeOrigin::Property(p) => p,
            TimeOrigin::M => "M",
        }
    }
}

/// One time value: unix seconds and the kind it was written in.
///
/// # Errors
/// A message when `v` is neither a finite number nor an RFC 3339 string with an offset.
pub fn read_time(v: &Value) -> Result<(f64, TimeFormat), String> {
    match v {
        Value::Number(n) => match n.as_f64() {
            Some(t) if t.is_finite() => Ok((t, TimeFormat::UnixS)),
            _ => Err(format!("{n} is not a finite number of seconds")),
        },
        Value::String(s) => parse_rfc3339(s).map(|t| (t, TimeFormat::Rfc3339)),
        other => Err(format!(
            "a time is an RFC 3339 string or a number of unix seconds, got {}",
            super::curve::positions::json_kind(other)
        )),
    }
}

/// Unix seconds of an RFC 3339 time (`2010-10-03T09:36:30Z`, `...+02:00`, fractional seconds
/// allowed).
///
/// # Errors
/// A message saying why the string is not one.
pub fn parse_rfc3339(s: &str) -> Result<f64, String> {
    let ts: jiff::Timestamp = s.parse().map_err(|e| {
        format!("{s:?} is not an RFC 3339 time with an offset (such as 2010-10-03T09:36:30Z): {e}")
    })?;
    Ok(ts.as_second() as f64 + ts.subsec_nanosecond() as f64 * 1e-9)
}

/// The times of a query (`at=`): comma-separated RFC 3339 strings or unix seconds, mixed as
/// wanted, in any order.
///
/// # Errors
/// A message naming the first entry that is neither.
pub fn parse_time_list(s: &str) -> Result<Vec<f64>, String> {
    s.split(',')
        .enumerate()
        .map(|(i, item)| {
            let item = item.trim();
            if item.is_empty() {
                return Err(format!("entry {i} is empty"));
            }
            if let Some(t) = crate::earth::parse_json_number(item) {
                if t.is_finite() {
                    return Ok(t);
                }
            }
            parse_rfc3339(item).map_err(|m| format!("entry {i}: {m}"))
        })
        .collect()
}

/// The times of one line, as read.
#[derive(Clone, Debug, PartialEq)]
pub struct LineTimes {
    /// Unix seconds, one per position.
    pub unix_s: Vec<f64>,
    /// How they were written.
    pub format: TimeFormat,
    /// Where they came from.
    pub origin: TimeOrigin,
    /// Pointer of the array (property) or of the coordinates (M), for errors.
    pub pointer: String,
}

impl LineTimes {
    /// Pointer of time `i`: `.../coordTimes/i`, or `.../coordinates/i/3` for M.
    pub fn pointer_of(&self, i: usize) -> String {
        match self.origin {
            TimeOrigin::Property(_) => format!("{}/{i}", self.pointer),
            TimeOrigin::M => format!("{}/{i}/3", self.pointer),
        }
    }
}

/// Reads a line's times from a property value (an array with one time per position).
///
/// # Errors
/// [`Problem::InvalidTime`] at the array or the offending entry.
pub fn times_from_array(
    v: &Value,
    pointer: &str,
    positions: usize,
    origin: TimeOrigin,
) -> Result<LineTimes, EarthError> {
    let bad = |ptr: String, msg: String| EarthError::new(ptr, Problem::InvalidTime(msg));
    let arr = v.as_array().ok_or_else(|| {
        bad(
            pointer.to_string(),
            format!(
                "expected an array with one time per position, got {}",
                super::curve::positions::json_kind(v)
            ),
        )
    })?;
    if arr.len() != positions {
        return Err(bad(
            pointer.to_string(),
            format!(
                "{} times for {positions} positions: give one time per position",
                arr.len()
            ),
        ));
    }
    let mut unix_s = Vec::with_capacity(arr.len());
    let mut format = None;
    for (i, x) in arr.iter().enumerate() {
        let (t, f) = read_time(x).map_err(|m| bad(format!("{pointer}/{i}"), m))?;
        match format {
            None => format = Some(f),
            Some(g) if g != f => {
                return Err(bad(
                    format!("{pointer}/{i}"),
                    format!(
                        "this time is {} but the first is {}: write all times of a line one way",
                        kind_text(f),
                        kind_text(g)
                    ),
                ))
            }
            Some(_) => {}
        }
        unix_s.push(t);
    }
    Ok(LineTimes {
        unix_s,
        format: format.unwrap_or(TimeFormat::UnixS),
        origin,
        pointer: pointer.to_string(),
    })
}

fn kind_text(f: TimeFormat) -> &'static str {
    match f {
        TimeFormat::Rfc3339 => "an RFC 3339 string",
        TimeFormat::UnixS => "a number",
    }
}

/// Checks that times strictly increase, allowing a repeated time only where `same_position(i)`
/// says position `i` repeats position `i - 1` (then `i` is a duplicate record). Returns which
/// positions are such duplicates.
///
/// # Errors
/// [`Problem::InvalidTime`] at the first time that does not increase.
pub fn check_times(
    times: &LineTimes,
    same_position: impl Fn(usize) -> bool,
) -> Result<Vec<bool>, EarthError> {
    let t = &times.unix_s;
    let mut duplicate = vec![false; t.len()];
    for i in 1..t.len() {
        if t[i] > t[i - 1] {
            continue;
        }
        let msg = if t[i] == t[i - 1] {
            if same_position(i) {
                duplicate[i] = true;
                continue;
            }
            format!(
                "time {i} equals time {} ({}) at a different position: times must strictly increase (a record repeated exactly, same time and position, is dropped)",
                i - 1,
                times.format.write(t[i])
            )
        } else {
            format!(
                "time {i} ({}) is earlier than time {} ({}): times must strictly increase",
                times.format.write(t[i]),
                i - 1,
                times.format.write(t[i - 1])
            )
        };
        return Err(EarthError::new(
            times.pointer_of(i),
            Problem::InvalidTime(msg),
        ));
    }
    if t.len() >= 2 && !(t[t.len() - 1] - t[0]).is_finite() {
        return Err(EarthError::new(
            times.pointer.clone(),
            Problem::InvalidTime("the times span more than the largest finite number".into()),
        ));
    }
    Ok(duplicate)
}

/// The affine map between a track's times and its curve's parameter on `[0, 1]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TimeMap {
    /// Unix seconds at parameter 0.
    pub start_unix_s: f64,
    /// Unix seconds at parameter 1.
    pub end_unix_s: f64,
    /// How times are written out.
    pub format: TimeFormat,
}

impl TimeMap {
    /// The curve parameter at a time.
    pub fn param(&self, unix_s: f64) -> f64 {
        (unix_s - self.start_unix_s) / self.duration_s()
    }

    /// The time at a curve parameter.
    pub fn time(&self, u: f64) -> f64 {
        if u >= 1.0 {
            return self.end_unix_s;
        }
        self.start_unix_s + u * self.duration_s()
    }

    /// Seconds from start to end.
    pub fn duration_s(&self) -> f64 {
        self.end_unix_s - self.start_unix_s
    }

    /// `properties.fit.time`: `start`, `end` (in the input's convention), `start_unix_s`,
    /// `end_unix_s`, `format` and `source`.
    pub fn to_json(&self, origin: &TimeOrigin) -> Value {
        json!({
            "start": self.format.write(self.start_unix_s),
            "end": self.format.write(self.end_unix_s),
            "start_unix_s": self.start_unix_s,
            "end_unix_s": self.end_unix_s,
            "format": self.format.name(),
            "source": origin.name(),
        })
    }

    /// Reads `properties.fit.time` (as written by [`TimeMap::to_json`]) at `pointer`.
    ///
    /// # Errors
    /// [`Problem::InvalidSpline`] naming the field.
    pub fn from_json(v: &Value, pointer: &str) -> Result<(TimeMap, TimeOrigin), EarthError> {
        let bad = |field: &str, msg: &str| {
            EarthError::new(
                format!("{pointer}/{field}"),
                Problem::InvalidSpline(msg.to_string()),
            )
        };
        let m: &Map<String, Value> = v.as_object().ok_or_else(|| {
            EarthError::new(
                pointer,
                Problem::InvalidSpline(
                    "expected {\"start_unix_s\", \"end_unix_s\", \"format\", \"source\"}".into(),
                ),
            )
        })?;
        let num = |field: &str| {
            m.get(field)
                .and_then(Value::as_f64)
                .filter(|x| x.is_finite())
                .ok_or_else(|| bad(field, "expected a finite number of unix seconds"))
        };
        let start = num("start_unix_s")?;
        let end = num("end_unix_s")?;
        if !(end > start && (end - start).is_finite()) {
            return Err(bad("end_unix_s", "the end must be later than the start"));
        }
        let format = m
            .get("format")
            .and_then(Value::as_str)
            .and_then(TimeFormat::from_name)
            .ok_or_else(|| bad("format", "expected \"rfc3339\" or \"unix_s\""))?;
        let origin = match m.get("source").and_then(Value::as_str) {
            Some("M") => TimeOrigin::M,
            Some(p) => TimeOrigin::Property(p.to_string()),
            None => return Err(bad("source", "expected the property name or \"M\"")),
        };
        Ok((
            TimeMap {
                start_unix_s: start,
                end_unix_s: end,
                format,
            },
            origin,
        ))
    }
}

/// Position, speed and heading of a curve in time at one time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Motion {
    /// The position (unit vector).
    pub point: [f64; 3],
    /// Speed over the ground along the curve, metres per second.
    pub speed_mps: f64,
    /// Direction of motion, degrees clockwise from north in [0, 360); 0 when not moving.
    pub heading_deg: f64,
}

/// Step of the difference quotient, in curve parameter (a span of [0, 1]): small enough that
/// its truncation error (of order step² times the third derivative) is far below GPS
/// precision, large enough that f64 rounding of the positions (1e-16) stays below 1e-9 of the
/// quotient.
const DERIVATIVE_STEP: f64 = 1e-6;

/// The position, speed and heading of `spline` (parameter `map.param(t)`) at unix time `t`.
///
/// The derivative is a second-order difference quotient taken inside the knot span holding
/// the parameter (central inside, one-sided near the span's ends), so at a joint where the
/// curve is only C0 it is the derivative going forward (the last span's, at the end).
pub fn motion(spline: &SphericalBSpline, map: &TimeMap, unix_s: f64) -> Motion {
    let (a, b) = spline.domain();
    let u = map.param(unix_s).clamp(a, b);
    let knots = spline.knots();
    // The span [lo, hi) holding u (the last one for u = b).
    let hi_i = knots.partition_point(|&k| k <= u);
    let hi = if hi_i < knots.len() && knots[hi_i] <= b {
        knots[hi_i]
    } else {
        b
    };
    let lo = knots[..hi_i]
        .iter()
        .rev()
        .copied()
        .find(|&k| k < hi)
        .unwrap_or(a);
    let h = DERIVATIVE_STEP.min(0.25 * (hi - lo));
    let at = |x: f64| -> [f64; 3] {
        let p = spline.evaluate(x);
        [p[0], p[1], p[2]]
    };
    let p = at(u);
    let d: [f64; 3] = if u - h >= lo && u + h <= hi {
        let (f, g) = (at(u + h), at(u - h));
        std::array::from_fn(|k| (f[k] - g[k]) / (2.0 * h))
    } else if u + 2.0 * h <= hi {
        let (f1, f2) = (at(u + h), at(u + 2.0 * h));
        std::array::from_fn(|k| (-3.0 * p[k] + 4.0 * f1[k] - f2[k]) / (2.0 * h))
    } else {
        let (g1, g2) = (at(u - h), at(u - 2.0 * h));
        std::array::from_fn(|k| (3.0 * p[k] - 4.0 * g1[k] + g2[k]) / (2.0 * h))
    };
    // Tangential part (the curve stays on the sphere, so d is tangent up to rounding).
    let dot = d[0] * p[0] + d[1] * p[1] + d[2] * p[2];
    let v: [f64; 3] = std::array::from_fn(|k| d[k] - dot * p[k]);
    let speed_rad_per_u = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    let speed_mps = super::lonlat::rad_to_m(speed_rad_per_u) / map.duration_s();
    // East and north at p.
    let (lon, lat) = (p[1].atan2(p[0]), p[2].clamp(-1.0, 1.0).asin());
    let east = [-lon.sin(), lon.cos(), 0.0];
    let north = [-lat.sin() * lon.cos(), -lat.sin() * lon.sin(), lat.cos()];
    let ve = v[0] * east[0] + v[1] * east[1];
    let vn = v[0] * north[0] + v[1] * north[1] + v[2] * north[2];
    let heading_deg = if speed_rad_per_u > 0.0 {
        ve.atan2(vn).to_degrees().rem_euclid(360.0)
    } else {
        0.0
    };
    Motion {
        point: p,
        speed_mps,
        heading_deg,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rfc3339_and_unix_read_alike() {
        let (a, fa) = read_time(&json!("2010-10-03T09:36:30Z")).unwrap();
        let (b, fb) = read_time(&json!(1286098590)).unwrap();
        assert_eq!((a, fa, fb), (b, TimeFormat::Rfc3339, TimeFormat::UnixS));
        let (c, _) = read_time(&json!("2010-10-03T11:36:30.5+02:00")).unwrap();
        assert_eq!(c, b + 0.5);
        assert!(
            read_time(&json!("2010-10-03T09:36:30")).is_err(),
            "no offset"
        );
        assert!(read_time(&json!("yesterday")).is_err());
        assert!(read_time(&json!(null)).is_err());
        assert_eq!(
            TimeFormat::Rfc3339.write(1286098590.25),
            json!("2010-10-03T09:36:30.25Z")
        );
        assert_eq!(
            TimeFormat::Rfc3339.write(1286098590.0),
            json!("2010-10-03T09:36:30Z")
        );
        assert_eq!(TimeFormat::UnixS.write(1.0000001), json!(1.0));
    }

    #[test]
    fn time_lists_mix_conventions() {
        let t = parse_time_list("1286098590,2010-10-03T09:36:31Z, 5e2").unwrap();
        assert_eq!(t, vec![1286098590.0, 1286098591.0, 500.0]);
        assert!(parse_time_list("1,,2").unwrap_err().contains("entry 1"));
        assert!(parse_time_list("1,soon").unwrap_err().contains("entry 1"));
        assert!(parse_time_list("NaN").is_err());
    }

    #[test]
    fn arrays_are_checked_with_pointers() {
        let o = || TimeOrigin::Property("t".into());
        let e = times_from_array(&json!([1, 2]), "/p/t", 3, o()).unwrap_err();
        assert_eq!(e.pointer, "/p/t");
        let e =
            times_from_array(&json!([1, "2010-10-03T09:36:30Z", 3]), "/p/t", 3, o()).unwrap_err();
        assert_eq!(e.pointer, "/p/t/1");
        let e = times_from_array(&json!([1, true, 3]), "/p/t", 3, o()).unwrap_err();
        assert_eq!(e.pointer, "/p/t/1");
        let lt = times_from_array(&json!([1, 2, 2, 1]), "/p/t", 4, o()).unwrap();
        // 2 repeats 1 at the same position: a duplicate record; 3 goes back in time.
        let e = check_times(&lt, |i| i == 2).unwrap_err();
        assert_eq!(e.pointer, "/p/t/3");
        assert!(e.to_string().contains("earlier"), "{e}");
        let e = check_times(&lt, |_| false).unwrap_err();
        assert_eq!(e.pointer, "/p/t/2");
        let lt = times_from_array(&json!([1, 2, 2, 3]), "/p/t", 4, o()).unwrap();
        assert_eq!(
            check_times(&lt, |i| i == 2).unwrap(),
            vec![false, false, true, false]
        );
        let m = LineTimes {
            origin: TimeOrigin::M,
            pointer: "/g/coordinates".into(),
            ..lt
        };
        assert_eq!(m.pointer_of(5), "/g/coordinates/5/3");
    }

    #[test]
    fn the_map_round_trips_through_json() {
        let m = TimeMap {
            start_unix_s: 100.0,
            end_unix_s: 300.0,
            format: TimeFormat::Rfc3339,
        };
        assert_eq!(m.param(200.0), 0.5);
        assert_eq!(m.time(0.25), 150.0);
        let j = m.to_json(&TimeOrigin::Property("coordTimes".into()));
        assert_eq!(j["start"], json!("1970-01-01T00:01:40Z"));
        let (back, origin) = TimeMap::from_json(&j, "/t").unwrap();
        assert_eq!(back, m);
        assert_eq!(origin, TimeOrigin::Property("coordTimes".into()));
        let e = TimeMap::from_json(
            &json!({"start_unix_s": 1, "end_unix_s": 1, "format": "unix_s", "source": "M"}),
            "/t",
        )
        .unwrap_err();
        assert_eq!(e.pointer, "/t/end_unix_s");
    }

    #[test]
    fn motion_along_the_equator_is_due_east_at_constant_speed() {
        use crate::sphere::PointSet;
        // A degree-1 spline from lon 0 to lon 1 on the equator, 1000 s: 111.19 km / 1000 s.
        let rows = [
            crate::earth::lonlat_to_unit(0.0, 0.0),
            crate::earth::lonlat_to_unit(1.0, 0.0),
        ];
        let s = SphericalBSpline::try_new(
            1,
            vec![0.0, 0.0, 1.0, 1.0],
            PointSet::try_from_rows(&rows).unwrap(),
        )
        .unwrap();
        let map = TimeMap {
            start_unix_s: 0.0,
            end_unix_s: 1000.0,
            format: TimeFormat::UnixS,
        };
        let want = crate::earth::rad_to_m(1f64.to_radians()) / 1000.0;
        for t in [0.0, 250.0, 1000.0] {
            let m = motion(&s, &map, t);
            assert!(
                (m.speed_mps - want).abs() < 1e-6 * want,
                "{t}: {}",
                m.speed_mps
            );
            assert!(
                (m.heading_deg - 90.0).abs() < 1e-6,
                "{t}: {}",
                m.heading_deg
            );
        }
    }
}
