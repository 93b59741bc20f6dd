//! Foot-point parameter correction: each data point's parameter moves to (near) the parameter
//! of the closest point of the curve, the parameters staying non-decreasing and the two end
//! points keeping 0 and 1.
//!
//! The paper fixes the parameters once (chord length) and only moves control points. On real
//! lines the chord-length parameter of a point is often far from where the fitted curve passes
//! it (a sparse straight stretch next to a dense meander is traversed at a very different speed
//! by the curve than by the data), and the parametric error `angle(q_j, C(t_j))` then measures
//! that mismatch, not the distance from the line. Alternating control-point updates with this
//! correction (the classical "parameter correction" of curve fitting, Hoschek 1988) lets the
//! least-squares loss see distances; the error reported stays parametric, now at the corrected
//! parameters, so it is still never smaller than the closest-point distance.

use crate::sphere::curve::bspline::{with_degree, Degree, Frame, Scratch, SphericalBSpline};
use crate::sphere::geometry::point::{angle, Dynamic, PointSet};
use rayon::prelude::*;

/// Newton steps per point and correction.
const NEWTON_STEPS: usize = 4;

/// Points per parallel work item.
const CHUNK: usize = 2048;

/// Moves every interior parameter towards its foot point on `spline` and returns how many
/// moved. Each new parameter stays within its neighbours' old parameters, a step is kept only
/// when it lowers that point's error, and a last pass restores the order where two neighbours
/// crossed (the later one moves back, never below its predecessor).
pub fn correct_parameters(
    spline: &SphericalBSpline,
    points: &PointSet,
    params: &mut [f64],
) -> usize {
    let n = params.len();
    if n < 3 {
        return 0;
    }
    let old = params.to_vec();
    let dim = spline.dim();
    let p = spline.degree();
    let moved: Vec<(usize, f64)> = (1..n - 1)
        .collect::<Vec<_>>()
        .par_chunks(CHUNK)
        .flat_map_iter(|js| {
            let frame = Frame::new(p, spline.knots(), spline.control_points());
            let mut work = FootScratch::new(p, dim);
            let mut out = Vec::new();
            for &j in js {
                let t = with_degree!(p, |g| foot_point(
                    &frame,
                    spline.knots(),
                    g,
                    points.get(j),
                    old[j],
                    (old[j - 1], old[j + 1]),
                    &mut work
                ));
                if t != old[j] {
                    out.push((j, t));
                }
            }
            out
        })
        .collect();
    for &(j, t) in &moved {
        params[j] = t;
    }
    for j in 1..n {
        if params[j] < params[j - 1] {
            params[j] = params[j - 1];
        }
    }
    params[0] = old[0];
    params[n - 1] = old[n - 1];
    moved.len()
}

/// The working memory of [`foot_point`], one per parallel work item: the de Boor scratch and
/// the curve points at the current and the trial parameter.
struct FootScratch {
    scratch: Scratch,
    c: Vec<f64>,
    c2: Vec<f64>,
}

impl FootScratch {
    fn new(p: usize, dim: usize) -> FootScratch {
        FootScratch {
            scratch: Scratch::new(p, dim),
            c: vec![0.0; dim],
            c2: vec![0.0; dim],
        }
    }
}

/// The parameter of `q`'s foot point on the curve, from `t0` by Newton steps, within
/// `[lo, hi]`; a step is kept only when it lowers the error.
fn foot_point<G: Degree>(
    frame: &Frame<'_>,
    knots: &[f64],
    g: G,
    q: &[f64],
    t0: f64,
    (lo, hi): (f64, f64),
    work: &mut FootScratch,
) -> f64 {
    let (scratch, c, c2) = (&mut work.scratch, &mut work.c[..], &mut work.c2[..]);
    let d = Dynamic(q.len());
    let dim = q.len();
    let eval = |t: f64, scratch: &mut Scratch, out: &mut [f64]| {
        let k = frame.span(t);
        frame.eval::<_, G, false, false>(d, g, k, t, scratch, out);
        k
    };
    let mut t = t0;
    eval(t, scratch, c);
    let mut e = angle(d, q, c);
    for _ in 0..NEWTON_STEPS {
        if e == 0.0 {
            break;
        }
        let k = eval(t, scratch, c);
        let width = (knots[k + 1] - knots[k]).max(1e-12);
        let h = 1e-4 * width;
        // One-sided difference inside the span: C' is smooth there (a knot may be a corner).
        let tb = if t + h <= knots[k + 1] { t + h } else { t - h };
        eval(tb, scratch, c2);
        let inv = 1.0 / (tb - t);
        let mut num = 0.0;
        let mut den = 0.0;
        for x in 0..dim {
            let dc = (c2[x] - c[x]) * inv;
            num += (q[x] - c[x]) * dc;
            den += dc * dc;
        }
        if den <= 0.0 || !num.is_finite() {
            break;
        }
        let mut step = num / den;
        let mut improved = false;
        for _ in 0..3 {
            let tn = (t + step).clamp(lo, hi);
            if tn == t {
                break;
            }
            eval(tn, scratch, c2);
            let en = angle(d, q, c2);
            if en < e {
                t = tn;
                e = en;
                improved = true;
                break;
            }
            step *= 0.5;
        }
        if !improved {
            break;
        }
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sphere::{fit, FitOptions, KnotPlacement};

    #[test]
    fn corrected_parameters_stay_ordered_and_lower_every_error() {
        // A wave sampled unevenly: dense first half, sparse second half.
        let rows: Vec<Vec<f64>> = (0..120)
            .map(|i| {
                let s = if i < 80 {
                    i as f64 / 160.0
                } else {
                    0.5 + (i - 80) as f64 / 78.0
                };
                let (lon, lat) = (s * 1.5, 0.2 * (6.0 * s).sin());
                vec![lat.cos() * lon.cos(), lat.cos() * lon.sin(), lat.sin()]
            })
            .collect();
        let pts = PointSet::try_from_rows(&rows).unwrap();
        let r = fit(
            &pts,
            None,
            &FitOptions::default()
                .with_control_points(10)
                .with_knots(KnotPlacement::Uniform),
        )
        .unwrap();
        let mut t = r.parameters.clone();
        let moved = correct_parameters(&r.spline, &pts, &mut t);
        assert!(moved > 0);
        assert_eq!((t[0], t[119]), (0.0, 1.0));
        assert!(t.windows(2).all(|w| w[1] >= w[0]));
        let before = crate::sphere::fit::metrics::pointwise_errors(&r.spline, &pts, &r.parameters);
        let after = crate::sphere::fit::metrics::pointwise_errors(&r.spline, &pts, &t);
        let (sb, sa): (f64, f64) = (before.iter().sum(), after.iter().sum());
        assert!(sa < 0.9 * sb, "{sa} vs {sb}");
    }
}
