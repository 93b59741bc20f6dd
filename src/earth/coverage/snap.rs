//! A coverage polyline's vertices put on the output grid one by one: of the four grid
//! positions around each interior vertex, the one that keeps the points it spans closest.
//!
//! Rounding each vertex to its nearest grid position ignores where the line is: a vertex fitted
//! with its points all on one side may round towards the far side and take a point over the
//! tolerance. Choosing among the grid corners around it by the points' own errors (and its own
//! distance from the input) keeps more
//! arcs fitted near the tolerance ([`crate::earth::curve::ToleranceRule::snap_target_rad`])
//! within it as written. The arc is then measured as always; this only picks positions.

use crate::earth::job::grid_neighbours;
use crate::earth::lonlat::{lonlat_to_unit, unit_to_lonlat};
use crate::sphere::curve::bspline::SphericalBSpline;
use crate::sphere::geometry::arc::distance_to_arc;
use crate::sphere::geometry::point::PointSet;

/// The degree-1 `fitted` spline with its interior vertices moved, left to right, to the grid
/// corner (of `multiple` steps of `precision` decimals) around each that makes the larger of
/// the errors of the points of its two segments (`params`: each point's parameter,
/// non-decreasing) and its own distance from the input there smallest, the nearest grid position kept on ties; its ends as in `rounded_ll` (junctions,
/// pinned). `None` for other degrees.
pub(super) fn snap_polyline(
    fitted: &SphericalBSpline,
    rounded_ll: &[[f64; 2]],
    points: &PointSet,
    params: &[f64],
    precision: u32,
    multiple: u32,
) -> Option<(SphericalBSpline, Vec<[f64; 2]>)> {
    let ctrl = fitted.control_points();
    let m = ctrl.len();
    if fitted.degree() != 1 || m < 3 || rounded_ll.len() != m || points.dim() != 3 {
        return None;
    }
    // Vertex i sits at knot i + 1 (clamped, degree 1); segment s holds the points whose
    // parameters lie in [u_s, u_{s+1}).
    let u = &fitted.knots()[1..=m];
    let mut start = vec![0usize; m];
    for (s, at) in start.iter_mut().enumerate().skip(1) {
        *at = params.partition_point(|&t| t < u[s]);
    }
    let seg = |s: usize| {
        start[s]..if s + 2 < m {
            start[s + 1]
        } else {
            params.len()
        }
    };
    let mut ll = rounded_ll.to_vec();
    let mut units: Vec<[f64; 3]> = ll.iter().map(|p| lonlat_to_unit(p[0], p[1])).collect();
    // The largest parametric error of segment s's points with ends a and b.
    let worst = |s: usize, a: &[f64; 3], b: &[f64; 3]| -> f64 {
        let span = u[s + 1] - u[s];
        seg(s)
            .map(|k| {
                let f = if span > 0.0 {
                    ((params[k] - u[s]) / span).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                angle(points.get(k), &slerp(a, b, f))
            })
            .fold(0.0, f64::max)
    };
    for i in 1..m - 1 {
        let (lon, lat) = unit_to_lonlat(ctrl.get(i));
        // The vertex's own distance from the input near it counts too (the other way of the
        // two-way distance): a vertex pushed off a corner to bring the points closer strays
        // from the line.
        let near = seg(i - 1).start.saturating_sub(1)..seg(i).end.min(points.len() - 1);
        let off_line = |c: &[f64; 3]| {
            near.clone()
                .map(|k| distance_to_arc(c, points.get(k), points.get(k + 1)))
                .fold(f64::INFINITY, f64::min)
        };
        let cost = |c: &[f64; 3]| {
            worst(i - 1, &units[i - 1], c)
                .max(worst(i, c, &units[i + 1]))
                .max(off_line(c))
        };
        let mut best = (cost(&units[i]), ll[i], units[i]);
        for x in grid_neighbours(lon, precision, multiple) {
            for y in grid_neighbours(lat, precision, multiple) {
                if x.abs() > 180.0 || y.abs() > 90.0 || [x, y] == ll[i] {
                    continue;
                }
                let c = lonlat_to_unit(x, y);
                let e = cost(&c);
                if e < best.0 {
                    best = (e, [x, y], c);
                }
            }
        }
        ll[i] = best.1;
        units[i] = best.2;
    }
    let rows = PointSet::try_from_rows(&units).ok()?;
    let spline = SphericalBSpline::try_new(1, fitted.knots().to_vec(), rows).ok()?;
    Some((spline, ll))
}

/// The angle between unit vectors.
fn angle(a: &[f64], b: &[f64; 3]) -> f64 {
    let cross = [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ];
    let sin = (cross[0] * cross[0] + cross[1] * cross[1] + cross[2] * cross[2]).sqrt();
    sin.atan2(a[0] * b[0] + a[1] * b[1] + a[2] * b[2])
}

/// The point a fraction `f` along the great-circle arc from `a` to `b`.
fn slerp(a: &[f64; 3], b: &[f64; 3], f: f64) -> [f64; 3] {
    let theta = angle(a, b);
    if theta < 1e-12 {
        return *a;
    }
    let (wa, wb) = (
        ((1.0 - f) * theta).sin() / theta.sin(),
        (f * theta).sin() / theta.sin(),
    );
    [
        wa * a[0] + wb * b[0],
        wa * a[1] + wb * b[1],
        wa * a[2] + wb * b[2],
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sphere::curve::bspline::clamped_uniform_knots;

    #[test]
    fn a_vertex_goes_to_the_grid_corner_nearer_its_points_not_the_nearest_one() {
        // A tent peaking at (0.05, 0.0101) degrees, fitted by a polyline whose apex sits at
        // latitude 0.0099. On a grid of 0.004 degrees the nearest latitude is 0.008 (0.0021
        // below the peak); 0.012 is 0.0019 above it.
        let tent: Vec<[f64; 3]> = (0..=20)
            .map(|i| {
                let lon = 0.005 * f64::from(i);
                lonlat_to_unit(lon, 0.0101 - 0.202 * (lon - 0.05).abs())
            })
            .collect();
        let points = PointSet::try_from_rows(&tent).unwrap();
        let apex = [0.05, 0.0099];
        let ctrl = PointSet::try_from_rows(&[
            lonlat_to_unit(0.0, 0.0),
            lonlat_to_unit(apex[0], apex[1]),
            lonlat_to_unit(0.1, 0.0),
        ])
        .unwrap();
        let fitted = SphericalBSpline::try_new(1, clamped_uniform_knots(3, 1), ctrl).unwrap();
        let params: Vec<f64> = (0..=20).map(|i| f64::from(i) / 20.0).collect();
        let nearest = [[0.0, 0.0], [0.052, 0.008], [0.1, 0.0]];
        let (spline, ll) = snap_polyline(&fitted, &nearest, &points, &params, 3, 4).unwrap();
        assert_eq!(ll[1][1], 0.012);
        assert!([0.048, 0.052].contains(&ll[1][0]), "{:?}", ll[1]);
        assert_eq!((ll[0], ll[2]), (nearest[0], nearest[2]), "ends stay");
        let worst = |s: &SphericalBSpline| {
            crate::sphere::fit::metrics::pointwise_errors(s, &points, &params)
                .into_iter()
                .fold(0.0, f64::max)
        };
        let (rounded, _) = crate::earth::curve::fitting::round_spline_with(&fitted, &|x| {
            crate::earth::job::round_to_grid(x, 3, 4)
        })
        .unwrap();
        assert!(
            worst(&spline) < worst(&rounded),
            "{} {}",
            worst(&spline),
            worst(&rounded)
        );
        // Not a degree-1 curve: nothing to choose.
        let quadratic = SphericalBSpline::try_new(
            2,
            clamped_uniform_knots(3, 2),
            fitted.control_points().clone(),
        )
        .unwrap();
        assert!(snap_polyline(&quadratic, &nearest, &points, &params, 3, 4).is_none());
    }
}
