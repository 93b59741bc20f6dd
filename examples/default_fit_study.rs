//! Measures fitting variants on GeoJSON LineStrings: the paper's default, uniform knots with
//! Gauss–Newton, and the ideas behind the default fit (adaptive knots, foot-point correction).
//!
//! `cargo run --release --example default_fit_study -- FILE.geojson [VARIANT ...]`
//! prints, per line and variant, max and mean parametric error in metres at the default number
//! of control points (a quarter of the points).

use spherefit::sphere::fit::adaptive_knots::{place, turning_angles, AdaptiveKnots};
use spherefit::sphere::fit::default_control_points;
use spherefit::sphere::fit::knots::parameters;
use spherefit::sphere::Parameterization;
use spherefit::sphere::{fit, FitOptions, KnotPlacement, PointSet, Solver};
use std::time::Instant;

const R: f64 = 6_371_008.8;

fn unit(lon: f64, lat: f64) -> Vec<f64> {
    let (lo, la) = (lon.to_radians(), lat.to_radians());
    vec![la.cos() * lo.cos(), la.cos() * lo.sin(), la.sin()]
}

fn variants() -> Vec<(&'static str, FitOptions)> {
    let paper = FitOptions::default();
    vec![
        ("paper", paper.clone()),
        (
            "uniform+gn",
            paper
                .clone()
                .with_knots(KnotPlacement::Uniform)
                .with_solver(Solver::GaussNewton),
        ),
        (
            "geodesic+gn",
            paper.clone().with_solver(Solver::GaussNewton),
        ),
        (
            "adaptive",
            paper.clone().with_knots(KnotPlacement::Adaptive),
        ),
        (
            "adaptive+fp",
            paper
                .clone()
                .with_knots(KnotPlacement::Adaptive)
                .with_parameter_correction(true),
        ),
        (
            "adaptive+fp100",
            paper
                .clone()
                .with_knots(KnotPlacement::Adaptive)
                .with_parameter_correction(true)
                .with_iterations(100),
        ),
        (
            "adaptive+gn",
            paper
                .clone()
                .with_knots(KnotPlacement::Adaptive)
                .with_solver(Solver::GaussNewton),
        ),
        (
            "adaptive+gn+fp",
            paper
                .clone()
                .with_knots(KnotPlacement::Adaptive)
                .with_solver(Solver::GaussNewton)
                .with_parameter_correction(true),
        ),
        (
            "uniform+gn+fp",
            paper
                .clone()
                .with_knots(KnotPlacement::Uniform)
                .with_solver(Solver::GaussNewton)
                .with_parameter_correction(true),
        ),
        ("geodesic+fp", paper.clone().with_parameter_correction(true)),
        (
            "geodesic+gn+fp",
            paper
                .clone()
                .with_solver(Solver::GaussNewton)
                .with_parameter_correction(true),
        ),
    ]
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let text = std::fs::read_to_string(&args[0]).expect("readable file");
    let doc: serde_json::Value = serde_json::from_str(&text).expect("JSON");
    let wanted: Vec<&str> = args[1..].iter().map(String::as_str).collect();
    let feats = doc["features"].as_array().expect("a FeatureCollection");
    let vs: Vec<_> = variants()
        .into_iter()
        .filter(|(n, _)| wanted.is_empty() || wanted.contains(n))
        .collect();
    let mut sums = vec![(0.0f64, 0.0f64, 0usize); vs.len()];
    for (fi, f) in feats.iter().enumerate() {
        let g = &f["geometry"];
        if g["type"] != "LineString" {
            continue;
        }
        let mut rows: Vec<Vec<f64>> = Vec::new();
        for c in g["coordinates"].as_array().unwrap() {
            let v = unit(c[0].as_f64().unwrap(), c[1].as_f64().unwrap());
            if rows.last().is_none_or(|l: &Vec<f64>| {
                l.iter().zip(&v).map(|(a, b)| (a - b).powi(2)).sum::<f64>() > 1e-20
            }) {
                rows.push(v);
            }
        }
        if rows.len() < 8 {
            continue;
        }
        let pts = PointSet::try_from_rows(&rows).unwrap();
        let frac: f64 = std::env::var("FRAC")
            .map(|x| x.parse().unwrap())
            .unwrap_or(0.25);
        let n_ctrl = if frac == 0.25 {
            default_control_points(pts.len(), 3)
        } else {
            ((pts.len() as f64 * frac).ceil() as usize)
                .max(4)
                .min(pts.len())
        };
        let name = f["properties"]["name"]
            .as_str()
            .map(str::to_string)
            .unwrap_or_else(|| format!("feature {fi}"));
        let mut line = format!("{name:22} {:5} pts {:4} ctrl |", pts.len(), n_ctrl);
        for (k, (vn, o)) in vs.iter().enumerate() {
            let t0 = Instant::now();
            let deg: usize = std::env::var("DEG")
                .map(|x| x.parse().unwrap())
                .unwrap_or(3);
            let mut o = o.clone().with_control_points(n_ctrl).with_degree(deg);
            if o.knots == KnotPlacement::Adaptive {
                if let Ok(cfg) = std::env::var("CFG") {
                    let v: Vec<f64> = cfg.split(',').map(|x| x.parse().unwrap()).collect();
                    let c = AdaptiveKnots {
                        corner_angle_rad: v[0].to_radians(),
                        corner_knot_share: v[1],
                        arc_length_share: v[2],
                        count_share: v[3],
                    };
                    let params = parameters(&pts, Parameterization::Chord).unwrap();
                    o = o.with_knot_vector(place(&pts, &params, n_ctrl, deg, &c));
                }
            }
            let r = fit(&pts, None, &o).unwrap();
            if std::env::var("WORST").is_ok() {
                let i = r.metrics.max_error_index;
                let turns = turning_angles(&pts);
                let gap = |a: usize, b: usize| {
                    spherefit::sphere::geometry::point::angle_between(pts.get(a), pts.get(b)) * R
                };
                eprintln!(
                    "{vn}: worst at {i} t={:.5} turn {:.0} deg, gaps {:.0} {:.0} m",
                    r.parameters[i],
                    turns[i].to_degrees(),
                    gap(i.saturating_sub(1), i),
                    gap(i, (i + 1).min(pts.len() - 1))
                );
            }
            let ms = t0.elapsed().as_secs_f64() * 1e3;
            let (mx, mn) = (r.metrics.max_error_rad * R, r.metrics.mean_error_rad * R);
            sums[k].0 = sums[k].0.max(mx);
            sums[k].1 += mn;
            sums[k].2 += 1;
            let k = r.spline.knots();
            let mut ts = Vec::new();
            for w in k.windows(2) {
                if w[1] > w[0] {
                    ts.extend((0..32).map(|i| w[0] + (w[1] - w[0]) * i as f64 / 32.0));
                }
            }
            ts.push(1.0);
            let c = r.spline.evaluate_many(&ts);
            let len: f64 = (1..c.len())
                .map(|i| spherefit::sphere::geometry::point::angle_between(c.get(i - 1), c.get(i)))
                .sum();
            let dl: f64 = (1..pts.len())
                .map(|i| {
                    spherefit::sphere::geometry::point::angle_between(pts.get(i - 1), pts.get(i))
                })
                .sum();
            line += &format!(
                " {vn} {:.0}/{:.0} m len {:.2} {:.0}ms |",
                mx,
                mn,
                len / dl,
                ms
            );
        }
        println!("{line}");
    }
    for (k, (vn, _)) in vs.iter().enumerate() {
        println!(
            "{vn:16} worst max {:.0} m, mean of means {:.0} m",
            sums[k].0,
            sums[k].1 / sums[k].2.max(1) as f64
        );
    }
}
