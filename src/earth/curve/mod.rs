//! One line or ring on the Earth: positions parsed and checked, repeats dropped, fitted (or
//! interpolated, or read from a spline document), rounded and sampled densely.
//!
//! Pointers in errors are relative to the document: `pointer` is where the line's coordinates
//! array sits (`/features/3/geometry/coordinates`), and a position error adds `/17` or `/17/1`.
//!
//! The files (this index re-exports nothing: each caller names the file it uses): `positions` (parsing, checks, repeats, errors mapped back
//! to the input position), `times` (a line's times as parameters), `fitting` (B-spline fits at
//! a count or to a tolerance), `interpolation` (Beta-splines), `stored` (lon/lat curve
//! documents read back and evaluated) and `output` (reports, dense lines, positions written).

pub mod compact;
pub mod fitting;
pub mod interpolation;
pub mod line;
pub mod output;
pub mod positions;
pub mod stored;
pub mod times;
pub mod tolerance_rule;

#[cfg(test)]
mod tests {
    use crate::earth::curve::fitting::fit_line;
    use crate::earth::curve::line::LineRef;
    use crate::earth::curve::line::OutputSpec;
    use crate::earth::curve::output::CurveOutput;
    use crate::earth::curve::positions::parse_positions;
    use crate::earth::curve::positions::DistinctPositions;
    use crate::earth::curve::stored::curve_from_lonlat_json;
    use crate::earth::error::EarthError;
    use crate::earth::error::Problem;
    use crate::earth::job::Limits;
    use crate::earth::job::OutputOptions;
    use crate::earth::lonlat::rad_to_m;
    use crate::earth::lonlat::unit_to_lonlat;
    use crate::sphere::curve::AnyCurve;
    use crate::sphere::fit::options::FitOptions;
    use crate::sphere::geometry::point::angle_between;
    use crate::sphere::geometry::point::PointSet;
    use serde_json::json;
    use serde_json::Value;

    fn coords(n: usize, f: impl Fn(f64) -> (f64, f64)) -> Value {
        json!((0..n)
            .map(|i| {
                let (a, b) = f(i as f64 / (n - 1) as f64);
                [a, b]
            })
            .collect::<Vec<_>>())
    }

    /// [`fit_line`] with the default output options and limits, not in time.
    fn fit_default(
        coords: &Value,
        pointer: &str,
        path: Vec<usize>,
        closed: bool,
        options: &FitOptions,
    ) -> Result<CurveOutput, EarthError> {
        let src = LineRef {
            value: coords,
            pointer,
            path: &path,
            closed,
        };
        let out = OutputSpec {
            output: &OutputOptions::default(),
            limits: &Limits::default(),
        };
        fit_line(src, options, None, out)
    }

    #[test]
    fn positions_are_checked_with_pointers() {
        let e = parse_positions(&json!([[0, 0], [1, 91]]), "/c").unwrap_err();
        assert_eq!(e.pointer, "/c/1/1");
        let e = parse_positions(&json!([[0, 0], [181, 1]]), "/c").unwrap_err();
        assert_eq!(e.pointer, "/c/1/0");
        let e = parse_positions(&json!([[0, 0], ["1", 1]]), "/c").unwrap_err();
        assert_eq!(e.pointer, "/c/1/0");
        let e = parse_positions(&json!([[0, 0, 5], [1, 1]]), "/c").unwrap_err();
        assert_eq!(e.pointer, "/c/1");
        let e = parse_positions(&json!([[0, 0], [1]]), "/c").unwrap_err();
        assert_eq!(e.pointer, "/c/1");
        let ok = parse_positions(&json!([[0, 0, 5], [1, 1, 6]]), "/c").unwrap();
        assert_eq!(ok.alts, Some(vec![5.0, 6.0]));
    }

    #[test]
    fn repeats_are_dropped_but_counted() {
        let line =
            parse_positions(&json!([[0, 0], [0, 0], [1, 0], [1, 0], [1, 0], [2, 0]]), "").unwrap();
        let d = DistinctPositions::from_line(&line);
        assert_eq!(d.len(), 3);
        assert_eq!(d.multiplicity, vec![2, 3, 1]);
        assert_eq!(d.input_index, vec![0, 2, 5]);
    }

    #[test]
    fn too_few_distinct_points_lower_the_degree_or_fail() {
        let opts = FitOptions::default();
        let r = fit_default(&json!([[0, 0], [1, 1], [1, 1]]), "/c", vec![], false, &opts).unwrap();
        assert_eq!(r.report.spline.unwrap().into_value()["degree"], 1);
        assert_eq!(r.report.fields["input_points"], 3);
        let e = fit_default(&json!([[0, 0], [0, 0]]), "/c", vec![], false, &opts).unwrap_err();
        assert!(matches!(
            e.problem,
            Problem::TooFewPoints { distinct: 1, .. }
        ));
    }

    #[test]
    fn antipodal_neighbours_point_at_the_second() {
        let e = fit_default(
            &json!([[0, 0], [10, 0], [-170, 0]]),
            "/c",
            vec![],
            false,
            &FitOptions::default(),
        )
        .unwrap_err();
        assert_eq!(e.pointer, "/c/2");
        assert!(matches!(e.problem, Problem::Antipodal { .. }));
    }

    #[test]
    fn a_ring_closes_exactly() {
        let ring = coords(61, |u| {
            let a = u * std::f64::consts::TAU;
            (
                10.0 + 3.0 * a.cos(),
                45.0 + 2.0 * a.sin() + 0.2 * (5.0 * a).sin(),
            )
        });
        let r = fit_default(
            &ring,
            "/c",
            vec![0],
            true,
            &FitOptions::default().with_control_points(12),
        )
        .unwrap();
        assert_eq!(r.points.first(), r.points.last());
        let doc = r.report.spline.clone().unwrap().into_value();
        let cps = doc["control_points"].as_array().unwrap();
        assert_eq!(cps.first(), cps.last());
        assert!(r.report.max_error_m < 20_000.0, "{}", r.report.max_error_m);
        let e = fit_default(
            &json!([[0, 0], [1, 0], [1, 1], [0, 1]]),
            "/c",
            vec![0],
            true,
            &FitOptions::default(),
        )
        .unwrap_err();
        assert_eq!(e.pointer, "/c/3");
    }

    #[test]
    fn altitude_follows_the_parameter() {
        let line = json!([
            [0, 0, 0],
            [1, 0, 100],
            [2, 0, 200],
            [3, 0, 300],
            [4, 0, 400]
        ]);
        let r = fit_default(&line, "", vec![], false, &FitOptions::default()).unwrap();
        assert!(r.has_alt);
        assert_eq!(r.alts[0], 0.0);
        assert_eq!(*r.alts.last().unwrap(), 400.0);
        // Along a great circle at constant speed, altitude ~ 100 m per degree of longitude.
        for (p, a) in r.points.iter().zip(&r.alts) {
            let (lon, _) = unit_to_lonlat(p);
            assert!((a - 100.0 * lon).abs() < 1.0, "{lon} {a}");
        }
    }

    #[test]
    fn reported_errors_are_those_of_the_returned_spline() {
        let line = coords(200, |u| (-20.0 + 40.0 * u, 5.0 * (8.0 * u).sin()));
        let r = fit_default(
            &line,
            "",
            vec![],
            false,
            &FitOptions::default().with_control_points(15),
        )
        .unwrap();
        let doc = &r.report.spline.clone().unwrap().into_value();
        let curve = match curve_from_lonlat_json(doc, "").unwrap() {
            AnyCurve::BSpline(s) => s,
            _ => unreachable!(),
        };
        let pts = parse_positions(&line, "").unwrap().points;
        let params = crate::sphere::fit::knots::parameters(
            &PointSet::try_from_rows(&pts).unwrap(),
            crate::sphere::Parameterization::Chord,
        )
        .unwrap();
        let c = curve.evaluate_many(&params);
        let max = pts
            .iter()
            .zip(c.iter())
            .map(|(p, q)| rad_to_m(angle_between(p, q)))
            .fold(0.0, f64::max);
        let reported = r.report.fields["max_error_m"].as_f64().unwrap();
        assert!((max - reported).abs() < 0.001, "{max} vs {reported}");
    }
}
