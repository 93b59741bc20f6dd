//! Points inserted along the great-circle segments of a polyline, so that a fit to points sees
//! the line: a border's sparse straight stretch (two vertices hundreds of kilometres apart) is
//! otherwise free for the curve to bulge over, since nothing is measured between its vertices.

use crate::sphere::geometry::point::{angle_between, slerp, PointSet};
use crate::sphere::SphereError;

/// The polyline through `points` with points inserted (on the great circle, evenly) into every
/// segment longer than `max_step_rad`, so no step is longer; at most `max_points` points in
/// all (the step is lengthened to keep to it). Returns the points and, for each input point,
/// its index in the output.
///
/// # Errors
/// [`SphereError::Antipodal`]-like errors of SLERP for antipodal neighbours.
///
/// # Example
/// ```
/// use spherefit::sphere::geometry::densify::densify;
/// use spherefit::sphere::PointSet;
/// let p = PointSet::try_from_rows(&[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]).unwrap();
/// let (d, at) = densify(&p, 0.1, 1000).unwrap();
/// assert_eq!(d.len(), 17); // pi/2 / 0.1 -> 16 steps
/// assert_eq!(at, vec![0, 16]);
/// ```
pub fn densify(
    points: &PointSet,
    max_step_rad: f64,
    max_points: usize,
) -> Result<(PointSet, Vec<usize>), SphereError> {
    let n = points.len();
    let steps: Vec<f64> = (1..n)
        .map(|i| angle_between(points.get(i - 1), points.get(i)))
        .collect();
    let mut step = max_step_rad;
    let pieces = |step: f64| -> usize {
        steps
            .iter()
            .map(|&s| {
                if step > 0.0 {
                    (s / step).ceil().max(1.0) as usize
                } else {
                    1
                }
            })
            .sum::<usize>()
            + 1
    };
    if !(step > 0.0 && step.is_finite()) || n < 2 {
        return Ok((points.clone(), (0..n).collect()));
    }
    while pieces(step) > max_points.max(n) {
        step *= 1.5;
    }
    let dim = points.dim();
    let mut out = Vec::with_capacity(pieces(step) * dim);
    let mut at = Vec::with_capacity(n);
    out.extend_from_slice(points.get(0));
    at.push(0);
    for i in 1..n {
        let k = (steps[i - 1] / step).ceil().max(1.0) as usize;
        for j in 1..k {
            out.extend(slerp(
                points.get(i - 1),
                points.get(i),
                j as f64 / k as f64,
            )?);
        }
        out.extend_from_slice(points.get(i));
        at.push(out.len() / dim - 1);
    }
    Ok((PointSet::from_flat_unchecked(dim, out), at))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sphere::geometry::arc::distance_to_arc;

    #[test]
    fn inserted_points_lie_on_the_segments_and_steps_are_short() {
        let rows = [
            [1.0, 0.0, 0.0],
            [0.6, 0.8, 0.0],
            [0.0, 0.6, 0.8],
            [0.0, 0.0, 1.0],
        ];
        let p = PointSet::try_from_rows(&rows).unwrap();
        let (d, at) = densify(&p, 0.05, 10_000).unwrap();
        assert_eq!(at.len(), 4);
        for (i, &k) in at.iter().enumerate() {
            assert_eq!(d.get(k), p.get(i));
        }
        for w in at.windows(2) {
            for k in w[0]..=w[1] {
                let e = distance_to_arc(
                    d.get(k),
                    p.get(at.iter().position(|&x| x == w[0]).unwrap()),
                    d.get(w[1]),
                );
                assert!(e < 1e-12, "{e}");
            }
        }
        for k in 1..d.len() {
            assert!(angle_between(d.get(k - 1), d.get(k)) <= 0.05 + 1e-12);
        }
    }

    #[test]
    fn the_point_limit_lengthens_the_step() {
        let p = PointSet::try_from_rows(&[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]).unwrap();
        let (d, _) = densify(&p, 1e-6, 100).unwrap();
        assert!(d.len() <= 100 && d.len() > 10);
    }
}
