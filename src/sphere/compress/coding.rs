//! The byte cost of a stored curve: one compact coding for every method the compression bench
//! compares (spline control points, knots and degree; polyline vertices), so that "bytes" means
//! the same thing for a spline, a Douglas–Peucker polyline and the optimal subset polyline.
//!
//! # The stream
//! Every integer is a LEB128 varint (7 bits a byte, low bits first); a signed one is zigzag
//! mapped first (`0, −1, 1, −2, … → 0, 1, 2, 3, …`). With `q` the coordinate quantum (radians;
//! the bench uses `T / 10`, [`quantum_for_tolerance`]):
//!
//! 1. **Header**: `dim`, degree `p`, control point count `N`, stored interior knot count `K`
//!    (unsigned). A polyline is a degree-1 curve with `K = 0` (its knots are the uniform ones,
//!    [`KnotRule::Uniform`]); a curve with uniform knots stores none either.
//! 2. **Knots**, only when `K > 0`: `b` (unsigned), then the `K` interior knots, each mapped to
//!    the domain `[0, 1]`, rounded to a multiple of `2^-b` and coded as the unsigned difference
//!    from the previous one (the first from 0; knots never decrease). `b` is the smallest with
//!    `2^-b · L <= q`, `L` the length of the control polygon (radians; at the curve's average
//!    speed a knot error of `2^-(b+1)` is about `q / 2` of arc), raised until no two distinct
//!    knots round to the same value and no two equal ones differ (so multiplicities survive).
//! 3. **Coordinates**, point by point: `dim − 1` angles, each rounded to a multiple of `q` and
//!    coded as the zigzag difference from the previous point's (the first from 0). The angles
//!    are longitude `λ = atan2(x₁, x₀)` and latitudes `β_k = atan2(x_k, |(x₀..x_{k−1})|)` for
//!    `k = 2 .. dim − 1`; on S^2 these are lon/lat. Longitude differences are taken modulo the
//!    `2·round(π/q) + 1` longitude steps, so crossing the antimeridian costs no more than any
//!    other step.
//!
//! The quantum is a parameter of the format, like the tolerance it comes from, and is not
//! stored. A decoded point is within `(q/2)·sqrt(dim − 1)` of the original (each angle is
//! within `q/2`, and the sphere's metric `dβ² + cos²β (…)` is at most the sum of the squared
//! angle changes); a knot within `2^-(b+1)` of the domain.

use crate::sphere::compress::tolerance::KnotRule;
use crate::sphere::curve::bspline::{clamped_uniform_knots, SphericalBSpline};
use crate::sphere::geometry::point::PointSet;
use crate::sphere::SphereError;
use std::f64::consts::PI;

/// The coordinate quantum for a tolerance: a tenth of it, so that quantising moves a point by
/// at most 7% of the tolerance on S^2.
pub fn quantum_for_tolerance(tolerance_rad: f64) -> f64 {
    tolerance_rad / 10.0
}

/// Smallest quantum accepted: an angle of π is then ~4.5e15 steps, still exact in an f64 and
/// an i64.
pub const MIN_QUANTUM_RAD: f64 = 1e-15;

/// Largest ambient dimension a stream may declare (S^63): bounds what a decoder allocates per
/// point before reading it.
pub const MAX_DIM: usize = 64;

/// Why a curve cannot be coded or a stream decoded.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CodingError {
    /// The quantum is not a finite number of at least [`MIN_QUANTUM_RAD`].
    #[error("quantum_rad {quantum_rad} must be a finite number >= {MIN_QUANTUM_RAD}")]
    InvalidQuantum {
        /// The quantum given.
        quantum_rad: f64,
    },
    /// A polyline needs two vertices.
    #[error("a polyline needs at least 2 vertices, got {got}")]
    TooFewVertices {
        /// Vertices given.
        got: usize,
    },
    /// The stream ends inside a value or before what its header promises.
    #[error("stream truncated at byte {at}: {reading}")]
    Truncated {
        /// Byte offset where more was needed.
        at: usize,
        /// What was being read.
        reading: &'static str,
    },
    /// A varint longer than 64 bits, or a header value out of range.
    #[error("invalid value at byte {at}: {reason}")]
    Invalid {
        /// Byte offset of the value.
        at: usize,
        /// What is wrong.
        reason: String,
    },
    /// Bytes left over after the last coordinate.
    #[error("{extra} bytes after the end of the curve")]
    TrailingBytes {
        /// How many.
        extra: usize,
    },
    /// The decoded numbers do not make a valid curve.
    #[error("decoded curve is invalid: {0}")]
    Curve(#[from] SphereError),
}

fn check_quantum(quantum_rad: f64) -> Result<(), CodingError> {
    if quantum_rad.is_finite() && quantum_rad >= MIN_QUANTUM_RAD {
        Ok(())
    } else {
        Err(CodingError::InvalidQuantum { quantum_rad })
    }
}

/// Appends `v` as an unsigned LEB128 varint (7 bits a byte, high bit set on all but the last).
pub(crate) fn put_unsigned(out: &mut Vec<u8>, mut v: u64) {
    while v >= 0x80 {
        out.push((v as u8 & 0x7f) | 0x80);
        v >>= 7;
    }
    out.push(v as u8);
}

/// Zigzag mapping of a signed value to an unsigned one (small magnitudes stay small).
pub(crate) fn zigzag(v: i64) -> u64 {
    ((v << 1) ^ (v >> 63)) as u64
}

/// The inverse of [`zigzag`].
pub(crate) fn unzigzag(u: u64) -> i64 {
    ((u >> 1) as i64) ^ -((u & 1) as i64)
}

/// The `dim − 1` angles of a unit vector (longitude first, then the latitudes).
fn angles(x: &[f64]) -> Vec<f64> {
    let mut out = Vec::with_capacity(x.len() - 1);
    out.push(x[1].atan2(x[0]));
    let mut r2 = x[0] * x[0] + x[1] * x[1];
    for &xk in &x[2..] {
        out.push(xk.atan2(r2.sqrt()));
        r2 += xk * xk;
    }
    out
}

/// The unit vector of `angles` (the inverse of [`angles`]).
fn from_angles(a: &[f64]) -> Vec<f64> {
    let (s, c) = a[0].sin_cos();
    let mut x = vec![c, s];
    for &b in &a[1..] {
        let (s, c) = b.sin_cos();
        x.iter_mut().for_each(|v| *v *= c);
        x.push(s);
    }
    x
}

/// Longitude steps in the canonical index range `[-h, h]`, `h = round(π / q)`.
fn longitude_half_range(q: f64) -> i64 {
    (PI / q).round() as i64
}

fn wrap_index(i: i64, h: i64) -> i64 {
    let m = 2 * h + 1;
    if i > h {
        i - m
    } else if i < -h {
        i + m
    } else {
        i
    }
}

fn put_points(out: &mut Vec<u8>, points: &PointSet, q: f64) {
    let h = longitude_half_range(q);
    let mut prev = vec![0i64; points.dim() - 1];
    for x in points.iter() {
        for (k, a) in angles(x).into_iter().enumerate() {
            let mut i = (a / q).round() as i64;
            if k == 0 {
                i = wrap_index(i, h);
            }
            let mut d = i - prev[k];
            if k == 0 {
                d = wrap_index(d, h);
            }
            put_unsigned(out, zigzag(d));
            prev[k] = i;
        }
    }
}

/// Encodes a polyline (a degree-1 curve with uniform knots, see the module docs).
///
/// # Errors
/// [`CodingError::InvalidQuantum`], [`CodingError::TooFewVertices`].
///
/// # Example
/// ```
/// use spherefit::sphere::{compress::coding::encode_polyline, PointSet};
/// let q: f64 = 1e-6;
/// let rows = [[1.0, 0.0, 0.0], [(100.0 * q).cos(), (100.0 * q).sin(), 0.0]];
/// let bytes = encode_polyline(&PointSet::try_from_rows(&rows).unwrap(), q).unwrap();
/// // Header 4 bytes; (0, 0) 2 bytes; longitude +100 steps (zigzag 200) 2 bytes, latitude 1.
/// assert_eq!(bytes.len(), 9);
/// ```
pub fn encode_polyline(vertices: &PointSet, quantum_rad: f64) -> Result<Vec<u8>, CodingError> {
    check_quantum(quantum_rad)?;
    if vertices.len() < 2 {
        return Err(CodingError::TooFewVertices {
            got: vertices.len(),
        });
    }
    let mut out = Vec::new();
    for v in [vertices.dim(), 1, vertices.len(), 0] {
        put_unsigned(&mut out, v as u64);
    }
    put_points(&mut out, vertices, quantum_rad);
    Ok(out)
}

/// Encodes a spline: its interior knots are stored unless `rule` is [`KnotRule::Uniform`]
/// (which promises they are [`clamped_uniform_knots`]).
///
/// # Errors
/// [`CodingError::InvalidQuantum`].
pub fn encode_curve(
    spline: &SphericalBSpline,
    rule: KnotRule,
    quantum_rad: f64,
) -> Result<Vec<u8>, CodingError> {
    check_quantum(quantum_rad)?;
    let ctrl = spline.control_points();
    let p = spline.degree();
    let n = ctrl.len();
    let interior: Vec<f64> = match rule {
        KnotRule::Uniform => Vec::new(),
        KnotRule::Stored => {
            let (a, b) = spline.domain();
            spline.knots()[p + 1..n]
                .iter()
                .map(|u| ((u - a) / (b - a)).clamp(0.0, 1.0))
                .collect()
        }
    };
    let mut out = Vec::new();
    for v in [spline.dim(), p, n, interior.len()] {
        put_unsigned(&mut out, v as u64);
    }
    if !interior.is_empty() {
        let length: f64 = (1..n)
            .map(|i| crate::sphere::geometry::point::angle_between(ctrl.get(i - 1), ctrl.get(i)))
            .sum();
        let bits = knot_bits(&interior, length, quantum_rad);
        put_unsigned(&mut out, u64::from(bits));
        let scale = (bits as f64).exp2();
        let mut prev = 0u64;
        for u in &interior {
            let k = (u * scale).round() as u64;
            put_unsigned(&mut out, k - prev);
            prev = k;
        }
    }
    put_points(&mut out, ctrl, quantum_rad);
    Ok(out)
}

/// The knot precision `b` of the module docs.
fn knot_bits(interior: &[f64], length: f64, q: f64) -> u32 {
    let mut bits = 0u32;
    while bits < 52 && (-(bits as f64)).exp2() * length > q {
        bits += 1;
    }
    let keeps_pattern = |bits: u32| {
        let s = (bits as f64).exp2();
        interior
            .windows(2)
            .all(|w| (w[0] == w[1]) == ((w[0] * s).round() == (w[1] * s).round()))
            && interior.iter().all(|u| {
                (*u > 0.0) == ((u * s).round() > 0.0) && (*u < 1.0) == ((u * s).round() < s)
            })
    };
    while bits < 52 && !keeps_pattern(bits) {
        bits += 1;
    }
    bits
}

/// Byte reader with offsets for errors.
struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl Reader<'_> {
    fn unsigned(&mut self, reading: &'static str) -> Result<u64, CodingError> {
        let start = self.at;
        let mut v = 0u64;
        for shift in (0..64).step_by(7) {
            let b = *self.bytes.get(self.at).ok_or(CodingError::Truncated {
                at: self.at,
                reading,
            })?;
            self.at += 1;
            let part = u64::from(b & 0x7f);
            if shift == 63 && part > 1 {
                break;
            }
            v |= part << shift;
            if b & 0x80 == 0 {
                return Ok(v);
            }
        }
        Err(CodingError::Invalid {
            at: start,
            reason: format!("{reading}: varint longer than 64 bits"),
        })
    }

    fn count(&mut self, reading: &'static str, max: usize) -> Result<usize, CodingError> {
        let at = self.at;
        let v = self.unsigned(reading)?;
        if v > max as u64 {
            return Err(CodingError::Invalid {
                at,
                reason: format!("{reading} {v} is more than {max}"),
            });
        }
        Ok(v as usize)
    }

    fn left(&self) -> usize {
        self.bytes.len() - self.at
    }
}

/// Decodes a stream written by [`encode_curve`] or [`encode_polyline`] with the same quantum:
/// the curve on the domain [0, 1] and whether its knots were stored.
///
/// # Errors
/// [`CodingError`]: a bad quantum, a truncated or malformed stream (with the byte offset), or
/// numbers that make no valid curve.
pub fn decode_curve(
    bytes: &[u8],
    quantum_rad: f64,
) -> Result<(SphericalBSpline, KnotRule), CodingError> {
    check_quantum(quantum_rad)?;
    let mut r = Reader { bytes, at: 0 };
    let at = r.at;
    let dim = r.count("dim", MAX_DIM)?;
    if dim < 2 {
        return Err(CodingError::Invalid {
            at,
            reason: format!("dim {dim} is less than 2"),
        });
    }
    let degree = r.count("degree", 64)?;
    // Each control point takes at least dim - 1 bytes: check before allocating.
    let n = r.count("control point count", usize::MAX)?;
    let at_k = r.at;
    let k = r.count("stored knot count", usize::MAX)?;
    if n.saturating_mul(dim - 1).saturating_add(k) > r.left() {
        return Err(CodingError::Truncated {
            at: r.at,
            reading: "control points (the header promises more than the stream holds)",
        });
    }
    let knots = if k == 0 {
        if n <= degree {
            return Err(CodingError::Invalid {
                at: at_k,
                reason: format!("{n} control points for degree {degree}"),
            });
        }
        clamped_uniform_knots(n, degree)
    } else {
        if k + degree + 1 != n {
            return Err(CodingError::Invalid {
                at: at_k,
                reason: format!("{k} stored knots for {n} control points of degree {degree}"),
            });
        }
        let at_b = r.at;
        let bits = r.count("knot bits", 52)?;
        let scale = (bits as f64).exp2();
        let mut knots = vec![0.0; degree + 1];
        let mut acc = 0u64;
        for _ in 0..k {
            let at = r.at;
            acc = acc
                .checked_add(r.unsigned("knot")?)
                .filter(|&a| a as f64 <= scale)
                .ok_or(CodingError::Invalid {
                    at,
                    reason: format!("knot beyond the domain (knot bits at byte {at_b})"),
                })?;
            knots.push(acc as f64 / scale);
        }
        knots.extend(std::iter::repeat_n(1.0, degree + 1));
        knots
    };
    let h = longitude_half_range(quantum_rad);
    let mut prev = vec![0i64; dim - 1];
    let mut coords = Vec::with_capacity(n * dim);
    let mut a = vec![0.0; dim - 1];
    for _ in 0..n {
        for c in 0..dim - 1 {
            let at = r.at;
            let d = unzigzag(r.unsigned("coordinate")?);
            let mut i = prev[c].checked_add(d).ok_or(CodingError::Invalid {
                at,
                reason: "coordinate out of range".into(),
            })?;
            if c == 0 {
                i = wrap_index(i, h);
            }
            prev[c] = i;
            a[c] = i as f64 * quantum_rad;
        }
        coords.extend(from_angles(&a));
    }
    if r.left() > 0 {
        return Err(CodingError::TrailingBytes { extra: r.left() });
    }
    let rows: Vec<&[f64]> = coords.chunks(dim).collect();
    let ctrl = PointSet::try_from_rows(&rows)?;
    let rule = if k == 0 {
        KnotRule::Uniform
    } else {
        KnotRule::Stored
    };
    Ok((SphericalBSpline::try_new(degree, knots, ctrl)?, rule))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sphere::geometry::point::angle_between;
    use proptest::prelude::*;

    fn on(lon: f64, lat: f64) -> [f64; 3] {
        [lat.cos() * lon.cos(), lat.cos() * lon.sin(), lat.sin()]
    }

    fn unit(v: Vec<f64>) -> Vec<f64> {
        let l = v.iter().map(|x| x * x).sum::<f64>().sqrt();
        v.into_iter().map(|x| x / l).collect()
    }

    #[test]
    fn varints_and_zigzag() {
        for (v, len) in [
            (0u64, 1),
            (127, 1),
            (128, 2),
            (16_383, 2),
            (16_384, 3),
            (u64::MAX, 10),
        ] {
            let mut out = Vec::new();
            put_unsigned(&mut out, v);
            assert_eq!(out.len(), len, "{v}");
            let mut r = Reader { bytes: &out, at: 0 };
            assert_eq!(r.unsigned("test").unwrap(), v);
        }
        for (v, z) in [
            (0i64, 0u64),
            (-1, 1),
            (1, 2),
            (-2, 3),
            (i64::MAX, u64::MAX - 1),
            (i64::MIN, u64::MAX),
        ] {
            assert_eq!(zigzag(v), z);
            assert_eq!(unzigzag(z), v);
        }
        // 11 continuation bytes are more than 64 bits.
        let mut r = Reader {
            bytes: &[0xff; 11],
            at: 0,
        };
        assert!(matches!(
            r.unsigned("x"),
            Err(CodingError::Invalid { at: 0, .. })
        ));
    }

    #[test]
    fn hand_counted_sizes() {
        let q = 1e-6;
        // Three vertices: (0, 0); (+100 q, 0): lon zigzag 200 (2 bytes), lat 0 (1);
        // (+163 q, -1 q): lon +63 zigzag 126 (1), lat -1 zigzag 1 (1). 4 + 2 + 3 + 2 = 11.
        let rows = [on(0.0, 0.0), on(100.0 * q, 0.0), on(163.0 * q, -q)];
        let line = PointSet::try_from_rows(&rows).unwrap();
        assert_eq!(encode_polyline(&line, q).unwrap().len(), 11);
        // The same as a degree-1 uniform spline: the same bytes.
        let spline =
            SphericalBSpline::try_new(1, clamped_uniform_knots(3, 1), line.clone()).unwrap();
        assert_eq!(
            encode_curve(&spline, KnotRule::Uniform, q).unwrap(),
            encode_polyline(&line, q).unwrap()
        );
        // Stored knots: one interior knot at 0.5 of a polygon 163e-6 long: b = 8 (2^-8 * 163e-6
        // <= 1e-6 < 2^-7 * 163e-6), so the knot is 128: bits 1 byte, knot 2 bytes, plus 11.
        let knots = vec![0.0, 0.0, 0.5, 1.0, 1.0];
        let stored = SphericalBSpline::try_new(1, knots, line.clone()).unwrap();
        let bytes = encode_curve(&stored, KnotRule::Stored, q).unwrap();
        assert_eq!(bytes.len(), 14);
        assert_eq!(bytes[4], 8);
        // Crossing the antimeridian is one small step, not 2 pi.
        let rows = [on(PI - 2.0 * q, 0.0), on(-PI + 3.0 * q, 0.0)];
        let line = PointSet::try_from_rows(&rows).unwrap();
        let bytes = encode_polyline(&line, q).unwrap();
        // Header 4; first lon ~3.14e6 steps: zigzag ~6.3e6, 4 bytes; lat 1; second: 2 bytes.
        assert_eq!(bytes.len(), 4 + 4 + 1 + 1 + 1, "{bytes:?}");
        let (back, _) = decode_curve(&bytes, q).unwrap();
        for i in 0..2 {
            assert!(
                angle_between(back.control_points().get(i), line.get(i)) <= 0.5 * q * 2f64.sqrt()
            );
        }
    }

    proptest! {
        /// decode(encode(x)) is within the quantum: every point within (q/2) sqrt(dim - 1),
        /// every knot within half a knot step, same degree and rule.
        #[test]
        fn round_trip_within_the_quantum(
            dim in 3usize..6,
            degree in 1usize..4,
            extra in 0usize..12,
            stored in any::<bool>(),
            q in prop::sample::select(vec![1e-9, 1.6e-8, 1e-6, 1e-3]),
            raw in prop::collection::vec(-1.0f64..1.0, 6 * 17),
            cuts in prop::collection::vec(0.0f64..1.0, 12),
        ) {
            let n = degree + 1 + extra;
            let rows: Vec<Vec<f64>> = (0..n).map(|i| unit(raw[i * dim..(i + 1) * dim].to_vec())).collect();
            // Keep neighbours apart from antipodal by construction: perturb towards the first.
            let ctrl = PointSet::try_from_rows(&rows).unwrap();
            prop_assume!(ctrl.check_no_antipodal_neighbours().is_ok());
            let mut interior: Vec<f64> = cuts[..n - degree - 1].to_vec();
            interior.sort_by(f64::total_cmp);
            let knots = if stored {
                let mut k = vec![0.0; degree + 1];
                k.extend(&interior);
                k.extend(vec![1.0; degree + 1]);
                k
            } else {
                clamped_uniform_knots(n, degree)
            };
            let spline = SphericalBSpline::try_new(degree, knots.clone(), ctrl.clone());
            prop_assume!(spline.is_ok());
            let spline = spline.unwrap();
            let rule = if stored { KnotRule::Stored } else { KnotRule::Uniform };
            let bytes = encode_curve(&spline, rule, q).unwrap();
            let (back, back_rule) = decode_curve(&bytes, q).unwrap();
            prop_assert_eq!(back_rule, if stored && n > degree + 1 { KnotRule::Stored } else { KnotRule::Uniform });
            prop_assert_eq!(back.degree(), degree);
            prop_assert_eq!(back.control_points().len(), n);
            let bound = 0.5 * q * ((dim - 1) as f64).sqrt() * (1.0 + 1e-9) + 1e-15;
            for i in 0..n {
                let e = angle_between(back.control_points().get(i), ctrl.get(i));
                prop_assert!(e <= bound, "point {} off by {} > {}", i, e, bound);
            }
            let step = if stored && n > degree + 1 { (-(bytes[4] as f64)).exp2() } else { 0.0 };
            for (a, b) in back.knots().iter().zip(&knots) {
                prop_assert!((a - b).abs() <= 0.5 * step + 1e-15, "knot {} vs {}", a, b);
            }
            // A polyline of the same points codes exactly as the degree-1 uniform curve.
            if degree == 1 && !stored {
                prop_assert_eq!(encode_polyline(&ctrl, q).unwrap(), bytes);
            }
        }
    }

    #[test]
    fn bad_streams_and_quanta_are_errors() {
        let line = PointSet::try_from_rows(&[on(0.0, 0.0), on(0.01, 0.02)]).unwrap();
        assert!(matches!(
            encode_polyline(&line, 0.0),
            Err(CodingError::InvalidQuantum { .. })
        ));
        assert!(matches!(
            encode_polyline(&line, f64::NAN),
            Err(CodingError::InvalidQuantum { .. })
        ));
        let one = PointSet::try_from_rows(&[on(0.0, 0.0)]).unwrap();
        assert_eq!(
            encode_polyline(&one, 1e-6),
            Err(CodingError::TooFewVertices { got: 1 })
        );
        let bytes = encode_polyline(&line, 1e-6).unwrap();
        assert!(decode_curve(&bytes, 1e-6).is_ok());
        for cut in 0..bytes.len() {
            assert!(
                matches!(
                    decode_curve(&bytes[..cut], 1e-6),
                    Err(CodingError::Truncated { .. })
                ),
                "{cut}"
            );
        }
        let mut longer = bytes.clone();
        longer.push(0);
        assert_eq!(
            decode_curve(&longer, 1e-6).unwrap_err(),
            CodingError::TrailingBytes { extra: 1 }
        );
        // A header promising a billion points is refused before allocating.
        let mut huge = vec![3, 1];
        put_unsigned(&mut huge, 1 << 30);
        huge.push(0);
        assert!(matches!(
            decode_curve(&huge, 1e-6),
            Err(CodingError::Truncated { .. })
        ));
        // dim 1, and stored knots that do not fit the count.
        assert!(matches!(
            decode_curve(&[1, 1, 2, 0, 0, 0], 1e-6),
            Err(CodingError::Invalid { at: 0, .. })
        ));
        assert!(matches!(
            decode_curve(&[3, 1, 2, 1, 0, 0, 0, 0, 0], 1e-6),
            Err(CodingError::Invalid { at: 3, .. })
        ));
    }
}
