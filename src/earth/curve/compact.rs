//! The compact curve: a fitted lon/lat B-spline as a few bytes, base64 in a JSON string, for
//! curve-aware readers (`carry=spline` writes it as `properties.fit.spline`; `evaluate`, in the
//! CLI, the service and Python, reads it wherever a spline document is read).
//!
//! # The stream (version 1)
//! Every integer after the version byte is a LEB128 varint (7 bits a byte, low bits first), a
//! signed one zigzag-mapped first (`0, −1, 1, −2, … → 0, 1, 2, 3, …`), as in
//! [`crate::sphere::compress::coding`]:
//!
//! 1. the version byte, `1`;
//! 2. `p`, the decimals of a degree the control points were rounded to (0 to 15);
//! 3. the degree, the control point count `n`, and `k`: 0 when the knots are the clamped
//!    uniform ones on [0, 1] (none stored), else `n + degree + 1`, the whole knot vector;
//! 4. when `k > 0`, the knots, each the difference of its IEEE-754 bits from the previous
//!    knot's (the first from 0.0): knots are non-negative and non-decreasing, whose bits are
//!    then non-decreasing too, so the differences are unsigned and the knots exact;
//! 5. per control point, `round(lon · 10^p)` and `round(lat · 10^p)` as zigzag differences from
//!    the previous point's (the first from 0).
//!
//! **Lossless at the fit's precision.** A fit rounds its control points to `p` decimals
//! before it certifies its two-way distance, and the knots are stored exactly, so the decoded
//! curve is the certified curve: the reported bound holds for it as it holds for the JSON
//! spline. Unlike [`crate::sphere::compress::coding`] (the bench's coding, quantised to a
//! tenth of the tolerance, knots on a 2^-b grid), nothing is rounded here that the fit did not
//! already round.
//!
//! **Hostile input.** The decoder ([`decode_compact`]) reads counts before it allocates and
//! refuses any count the remaining bytes cannot hold (each coordinate and knot takes at least
//! one byte), varints longer than 64 bits, an unknown version, decreasing knots (a bit sum past
//! infinity's bits, where the negative numbers lie, included), latitudes
//! beyond ±90° and longitudes beyond ±180°, and trailing bytes, each with the byte offset; the
//! curve it makes is then checked as a JSON spline is ([`curve_from_lonlat_json`](crate::earth::curve::stored::curve_from_lonlat_json)). The
//! base64 is the `base64` crate's standard engine (padded, canonical: a last character with
//! bits past the last byte is refused), its errors given with the character's offset.

use crate::sphere::compress::coding::{put_unsigned, unzigzag, zigzag};
use crate::sphere::curve::bspline::SphericalBSpline;
use base64::engine::general_purpose::STANDARD;
use base64::{DecodeError, Engine as _};
use serde_json::{json, Value};

/// The version byte this build writes and reads.
pub const COMPACT_VERSION: u8 = 1;

/// Highest degree a compact curve may declare (the fits write at most 5).
const MAX_COMPACT_DEGREE: u64 = 64;

/// Encodes a spline whose control points are `control_ll` (`[lon, lat]`, already rounded to
/// `precision` decimals) as the compact stream, base64. `None` when the knots cannot be coded
/// losslessly (a negative or non-finite knot), or `precision` is beyond 15: the JSON spline is
/// then the one to write.
pub fn encode_compact(
    spline: &SphericalBSpline,
    control_ll: &[[f64; 2]],
    precision: u32,
) -> Option<String> {
    if precision > 15 || control_ll.len() != spline.control_points().len() {
        return None;
    }
    let mut out = vec![COMPACT_VERSION];
    put_unsigned(&mut out, u64::from(precision));
    let knots = spline.knots();
    let uniform = spline.has_clamped_uniform_knots() && spline.domain() == (0.0, 1.0);
    put_unsigned(&mut out, spline.degree() as u64);
    put_unsigned(&mut out, control_ll.len() as u64);
    if uniform {
        put_unsigned(&mut out, 0);
    } else {
        if knots.iter().any(|u| !(u.is_finite() && *u >= 0.0)) {
            return None;
        }
        put_unsigned(&mut out, knots.len() as u64);
        let mut prev = 0u64;
        for u in knots {
            // +0.0: -0.0's bits would be the largest.
            let bits = (u + 0.0).to_bits();
            put_unsigned(&mut out, bits.checked_sub(prev)?);
            prev = bits;
        }
    }
    let scale = 10f64.powi(precision as i32);
    let mut prev = [0i64; 2];
    for p in control_ll {
        for c in 0..2 {
            let i = (p[c] * scale).round() as i64;
            put_unsigned(&mut out, zigzag(i - prev[c]));
            prev[c] = i;
        }
    }
    Some(base64_encode(&out))
}

/// Decodes a compact curve (base64 text) into the lon/lat spline document it stands for,
/// `{"degree", "knots", "control_points"}`, which [`curve_from_lonlat_json`](crate::earth::curve::stored::curve_from_lonlat_json) then checks.
///
/// # Errors
/// A message saying what is wrong and at which byte of the decoded stream (or which
/// character of the text), for every malformed input; never a panic, and nothing allocated
/// beyond what the input's own length allows.
pub fn decode_compact(text: &str, max_control_points: usize) -> Result<Value, String> {
    let bytes = base64_decode(text)?;
    let mut r = Reader {
        bytes: &bytes,
        at: 0,
    };
    let version = r.unsigned_byte()?;
    if version != COMPACT_VERSION {
        return Err(format!(
            "compact curve version {version} at byte 0: this build reads version {COMPACT_VERSION}"
        ));
    }
    let precision = r.count("precision", 15)?;
    let at_degree = r.at;
    let degree = r.count("degree", MAX_COMPACT_DEGREE as usize)?;
    if degree == 0 {
        return Err(format!(
            "degree 0 at byte {at_degree}: the degree is at least 1"
        ));
    }
    let n = r.count("control point count", max_control_points)?;
    let at_k = r.at;
    let k = r.count("knot count", usize::MAX)?;
    // Every coordinate and every knot takes at least one byte: check before allocating.
    if n.saturating_mul(2).saturating_add(k) > r.left() {
        return Err(format!(
            "the header (byte {at_k}) promises {n} control points and {k} knots, more than the {} bytes left hold",
            r.left()
        ));
    }
    if n <= degree {
        return Err(format!(
            "{n} control points for degree {degree} (byte {at_degree}): at least degree + 1"
        ));
    }
    let knots: Vec<f64> = if k == 0 {
        crate::sphere::curve::bspline::clamped_uniform_knots(n, degree)
    } else {
        if k != n + degree + 1 {
            return Err(format!(
                "{k} knots at byte {at_k} for {n} control points of degree {degree}: expected {}",
                n + degree + 1
            ));
        }
        let mut out = Vec::with_capacity(k);
        let mut bits = 0u64;
        for j in 0..k {
            let at = r.at;
            let d = r.unsigned("knot")?;
            bits = bits.checked_add(d).ok_or_else(|| {
                format!("knot {j} at byte {at} overflows (the knots must not decrease)")
            })?;
            // Past the bits of infinity lie the NaNs and then, with the sign bit set, the
            // negative numbers: a sum that gets there has gone below the knot before it (-0.0
            // up to -MAX are finite, so `is_finite` alone would let a knot decrease).
            if bits >= f64::INFINITY.to_bits() {
                return Err(format!(
                    "knot {j} at byte {at} is not a finite number at least the knot before it"
                ));
            }
            let u = f64::from_bits(bits);
            out.push(u);
        }
        out
    };
    let scale = 10f64.powi(precision as i32);
    let mut prev = [0i64; 2];
    let mut ctrl = Vec::with_capacity(n);
    for i in 0..n {
        let mut p = [0.0; 2];
        for c in 0..2 {
            let at = r.at;
            let d = unzigzag(r.unsigned("coordinate")?);
            let v = prev[c]
                .checked_add(d)
                .ok_or_else(|| format!("control point {i} at byte {at}: coordinate overflows"))?;
            prev[c] = v;
            p[c] = v as f64 / scale;
            let limit = if c == 0 { 180.0 } else { 90.0 };
            if p[c].abs() > limit {
                return Err(format!(
                    "control point {i} at byte {at}: {} {} is outside [-{limit}, {limit}]",
                    if c == 0 { "longitude" } else { "latitude" },
                    p[c]
                ));
            }
        }
        ctrl.push(p);
    }
    if r.left() > 0 {
        return Err(format!(
            "{} bytes after the last control point (byte {})",
            r.left(),
            r.at
        ));
    }
    Ok(json!({"degree": degree, "knots": knots, "control_points": ctrl}))
}

/// Byte reader whose errors say where.
struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl Reader<'_> {
    fn unsigned_byte(&mut self) -> Result<u8, String> {
        let b = *self
            .bytes
            .get(self.at)
            .ok_or_else(|| "empty compact curve: no version byte".to_string())?;
        self.at += 1;
        Ok(b)
    }

    fn unsigned(&mut self, reading: &str) -> Result<u64, String> {
        let start = self.at;
        let mut v = 0u64;
        for shift in (0..64).step_by(7) {
            let b = *self.bytes.get(self.at).ok_or_else(|| {
                format!("truncated at byte {} while reading the {reading}", self.at)
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
        Err(format!(
            "the {reading} at byte {start} is a varint longer than 64 bits"
        ))
    }

    fn count(&mut self, reading: &str, max: usize) -> Result<usize, String> {
        let at = self.at;
        let v = self.unsigned(reading)?;
        if v > max as u64 {
            return Err(format!("{reading} {v} at byte {at} is more than {max}"));
        }
        Ok(v as usize)
    }

    fn left(&self) -> usize {
        self.bytes.len() - self.at
    }
}

/// Standard base64 (RFC 4648 §4, padded), by the `base64` crate.
fn base64_encode(bytes: &[u8]) -> String {
    STANDARD.encode(bytes)
}

/// Decodes standard padded base64; errors name the character (its offset in the text) where
/// the crate reports one.
fn base64_decode(text: &str) -> Result<Vec<u8>, String> {
    STANDARD.decode(text).map_err(|e| match e {
        DecodeError::InvalidByte(at, c) => format!(
            "the compact curve is not base64: character {at} ({:?})",
            c as char
        ),
        DecodeError::InvalidLength(n) => format!(
            "the compact curve is not base64: {n} base64 characters, a length no padded base64 has"
        ),
        DecodeError::InvalidLastSymbol(at, c) => format!(
            "the compact curve is not base64: character {at} ({:?}) has bits past the last byte",
            c as char
        ),
        DecodeError::InvalidPadding => {
            "the compact curve is not base64: its padding (`=`) is wrong or missing".to_string()
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::earth::curve::stored::curve_from_lonlat_json;
    use crate::earth::lonlat::lonlat_to_unit;
    use crate::sphere::curve::bspline::clamped_uniform_knots;
    use crate::sphere::curve::AnyCurve;
    use crate::sphere::geometry::point::PointSet;
    use proptest::prelude::*;

    fn spline(degree: usize, knots: Vec<f64>, ll: &[[f64; 2]]) -> SphericalBSpline {
        let rows: Vec<[f64; 3]> = ll.iter().map(|p| lonlat_to_unit(p[0], p[1])).collect();
        SphericalBSpline::try_new(degree, knots, PointSet::try_from_rows(&rows).unwrap()).unwrap()
    }

    #[test]
    fn base64_round_trips_and_matches_rfc_4648() {
        for (raw, text) in [
            (&b""[..], ""),
            (b"f", "Zg=="),
            (b"fo", "Zm8="),
            (b"foo", "Zm9v"),
            (b"foobar", "Zm9vYmFy"),
        ] {
            assert_eq!(base64_encode(raw), text);
            assert_eq!(base64_decode(text).unwrap(), raw);
        }
        assert!(base64_decode("Zm9").is_err());
        assert!(base64_decode("Zm=v").is_err());
        assert!(base64_decode("Z!9v").unwrap_err().contains("character 1"));
    }

    #[test]
    fn a_uniform_and_a_stored_knot_spline_decode_to_the_same_document() {
        let ll = [
            [-117.1254, 32.5311],
            [-116.6754, 32.5651],
            [179.9, -10.0],
            [-179.5, 89.9],
        ];
        let s = spline(1, clamped_uniform_knots(4, 1), &ll);
        let text = encode_compact(&s, &ll, 4).unwrap();
        // Version, p, degree, n, k: 5 bytes, then 8 coordinates.
        let doc = decode_compact(&text, 100).unwrap();
        assert_eq!(doc["degree"], 1);
        assert_eq!(doc["control_points"], json!(ll));
        assert_eq!(doc["knots"], json!(clamped_uniform_knots(4, 1)));
        let knots = vec![0.0, 0.0, 0.0, 0.0, 0.3141592653589793, 1.0, 1.0, 1.0, 1.0];
        let ll5 = [[0.0, 0.0], [1.0, 0.5], [2.0, 0.25], [3.0, 1.0], [4.0, 0.0]];
        let s = spline(3, knots.clone(), &ll5);
        let doc = decode_compact(&encode_compact(&s, &ll5, 4).unwrap(), 100).unwrap();
        assert_eq!(doc["knots"], json!(knots), "knots are exact");
        let back = curve_from_lonlat_json(&doc, "").unwrap();
        let AnyCurve::BSpline(back) = back else {
            panic!("a B-spline")
        };
        assert_eq!(back.knots(), s.knots());
    }

    #[test]
    fn hostile_streams_are_errors_that_say_where() {
        let ll = [[0.0, 0.0], [1.0, 0.5], [2.0, 0.25]];
        let good = base64_decode(
            &encode_compact(&spline(1, clamped_uniform_knots(3, 1), &ll), &ll, 3).unwrap(),
        )
        .unwrap();
        let text = |b: &[u8]| base64_encode(b);
        // Wrong version.
        let mut v2 = good.clone();
        v2[0] = 2;
        assert!(decode_compact(&text(&v2), 100)
            .unwrap_err()
            .contains("version 2"));
        // Truncated anywhere.
        for cut in 0..good.len() {
            assert!(decode_compact(&text(&good[..cut]), 100).is_err(), "{cut}");
        }
        // Counts larger than the data: a billion points, refused before allocating.
        let mut huge = vec![1, 3, 1];
        put_unsigned(&mut huge, 1 << 30);
        huge.push(0);
        assert!(decode_compact(&text(&huge), usize::MAX)
            .unwrap_err()
            .contains("promises"));
        // ... or than the limit.
        assert!(decode_compact(&text(&good), 2)
            .unwrap_err()
            .contains("more than 2"));
        // A varint that overflows 64 bits.
        let mut over = vec![1, 3, 1, 3, 0];
        over.extend([0xff; 11]);
        over.extend([0; 6]);
        assert!(decode_compact(&text(&over), 100)
            .unwrap_err()
            .contains("longer than 64 bits"));
        // Decreasing knots: the bit difference cannot be negative, so the sum overflows.
        let mut dec = vec![1, 3, 1, 3, 5];
        put_unsigned(&mut dec, 0.5f64.to_bits());
        put_unsigned(&mut dec, u64::MAX - 10);
        dec.extend([0; 9]);
        let e = decode_compact(&text(&dec), 100).unwrap_err();
        assert!(e.contains("knot 1") && e.contains("byte"), "{e}");
        // A difference that carries the bits past infinity into the negative numbers: a
        // finite knot (-5e-324) below the one before it.
        let mut neg = vec![1, 3, 1, 3, 5];
        put_unsigned(&mut neg, 0.5f64.to_bits());
        put_unsigned(&mut neg, 0x8000_0000_0000_0001 - 0.5f64.to_bits());
        neg.extend([0; 9]);
        let e = decode_compact(&text(&neg), 100).unwrap_err();
        assert!(e.contains("knot 1 at byte"), "{e}");
        // A latitude past the pole; trailing bytes.
        let mut pole = vec![1, 0, 1, 2, 0, 0];
        put_unsigned(&mut pole, zigzag(91));
        pole.extend([0, 0]);
        assert!(decode_compact(&text(&pole), 100)
            .unwrap_err()
            .contains("latitude 91"));
        let mut long = good.clone();
        long.push(0);
        assert!(decode_compact(&text(&long), 100)
            .unwrap_err()
            .contains("after the last"));
    }

    proptest! {
        /// Random bytes never panic the decoder, and what it accepts is a document the JSON
        /// reader either takes or refuses with an error (never a panic).
        #[test]
        fn random_bytes_are_an_error_or_a_curve(bytes in prop::collection::vec(any::<u8>(), 0..64),
                                                  head in 0u8..3) {
            let mut b = bytes;
            if let Some(first) = b.first_mut() {
                *first = head; // reach past the version check often
            }
            if let Ok(doc) = decode_compact(&base64_encode(&b), 10_000) {
                let _ = curve_from_lonlat_json(&doc, "");
            }
        }

        /// Random text, base64 or not, never panics the decoder either.
        #[test]
        fn random_text_is_an_error_or_a_curve(text in "[A-Za-z0-9+/=!]{0,48}") {
            if let Ok(doc) = decode_compact(&text, 10_000) {
                let _ = curve_from_lonlat_json(&doc, "");
            }
        }

        /// Rounded control points and any knots round-trip exactly.
        #[test]
        fn encoded_curves_decode_exactly(
            p in 0u32..8,
            raw in prop::collection::vec((-179.0f64..179.0, -89.0f64..89.0), 4..12),
            cuts in prop::collection::vec(0.0f64..1.0, 8),
            stored in any::<bool>(),
        ) {
            let s = 10f64.powi(p as i32);
            let ll: Vec<[f64; 2]> = raw.iter().map(|(a, b)| [(a * s).round() / s, (b * s).round() / s]).collect();
            let n = ll.len();
            let degree = 3.min(n - 1);
            let knots = if stored {
                let mut inner: Vec<f64> = cuts[..n - degree - 1].to_vec();
                inner.sort_by(f64::total_cmp);
                let mut k = vec![0.0; degree + 1];
                k.extend(inner);
                k.extend(vec![1.0; degree + 1]);
                k
            } else {
                clamped_uniform_knots(n, degree)
            };
            let rows: Vec<[f64; 3]> = ll.iter().map(|q| lonlat_to_unit(q[0], q[1])).collect();
            let Ok(ctrl) = PointSet::try_from_rows(&rows) else { return Ok(()) };
            let Ok(sp) = SphericalBSpline::try_new(degree, knots.clone(), ctrl) else { return Ok(()) };
            let doc = decode_compact(&encode_compact(&sp, &ll, p).unwrap(), 100).unwrap();
            prop_assert_eq!(&doc["knots"], &json!(knots));
            prop_assert_eq!(&doc["control_points"], &json!(ll));
        }
    }
}
