//! Rust port of scripts/greedy_stabbing_estimate.py, to time the greedy ordered stabbing on a
//! whole file (an estimate, not the fitter): `cargo run --release --example greedy_estimate --
//! T SHARE LINES.geojson`.

use spherefit::earth::lonlat::{lonlat_to_unit, EARTH_RADIUS_M};
use std::time::Instant;

type V3 = [f64; 3];

fn dot(a: &V3, b: &V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: &V3, b: &V3) -> V3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn normed(a: V3) -> V3 {
    let n = dot(&a, &a).sqrt();
    [a[0] / n, a[1] / n, a[2] / n]
}

fn frame(v: &V3) -> (V3, V3) {
    let a = if v[0].abs() < 0.9 {
        [1.0, 0.0, 0.0]
    } else {
        [0.0, 1.0, 0.0]
    };
    let e1 = normed(cross(v, &a));
    let e2 = cross(v, &e1);
    (e1, e2)
}

struct Plane {
    v: V3,
    e1: V3,
    e2: V3,
}

impl Plane {
    fn at(v: V3) -> Plane {
        let (e1, e2) = frame(&v);
        Plane { v, e1, e2 }
    }
    fn xy(&self, q: &V3) -> Option<(f64, f64)> {
        let c = dot(q, &self.v);
        (c > 0.5).then(|| (dot(q, &self.e1) / c, dot(q, &self.e2) / c))
    }
}

fn run_from(pts: &[V3], i: usize, end: usize, pl: &Plane, eps: f64) -> (usize, (f64, f64)) {
    let n = pts.len();
    let (mut lo, mut hi, mut base) = (f64::NEG_INFINITY, f64::INFINITY, None::<f64>);
    let mut j = i;
    while j < end {
        let Some((x, y)) = pl.xy(&pts[j]) else { break };
        let r = x.hypot(y);
        let reach = if j == n - 1 { 0.0 } else { eps };
        if r > reach {
            let phi = y.atan2(x);
            let a = (reach / r).min(1.0).asin();
            let b = *base.get_or_insert(phi);
            let pi = std::f64::consts::PI;
            let d = (phi - b + pi).rem_euclid(2.0 * pi) - pi;
            let (nlo, nhi) = (lo.max(d - a), hi.min(d + a));
            if nlo > nhi {
                break;
            }
            lo = nlo;
            hi = nhi;
        }
        j += 1;
    }
    let psi = match base {
        None => 0.0,
        Some(b) if lo == f64::NEG_INFINITY => b,
        Some(b) => b + 0.5 * (lo + hi),
    };
    (j, (psi.cos(), psi.sin()))
}

fn ordered_until(pts: &[V3], i: usize, j: usize, pl: &Plane, u: (f64, f64), eps: f64) -> usize {
    let mut reach: f64 = 0.0;
    for (m, q) in pts.iter().enumerate().take(j).skip(i) {
        let (x, y) = pl.xy(q).expect("within the run");
        let t = x * u.0 + y * u.1;
        if t < reach && (x - reach * u.0).hypot(y - reach * u.1) > eps {
            return m;
        }
        reach = reach.max(t);
    }
    j
}

fn far_foot(pts: &[V3], i: usize, j: usize, pl: &Plane, u: (f64, f64)) -> f64 {
    pts[i..j].iter().fold(0.0, |t: f64, q| {
        let (x, y) = pl.xy(q).expect("within the run");
        t.max(x * u.0 + y * u.1)
    })
}

fn greedy(pts: &[V3], eps: f64) -> usize {
    let n = pts.len();
    let (mut v, mut count, mut i) = (pts[0], 1, 1);
    while i < n {
        let pl = Plane::at(v);
        let (mut j, mut u) = run_from(pts, i, n, &pl, eps);
        while j > i {
            let m = ordered_until(pts, i, j, &pl, u, eps);
            if m == j {
                break;
            }
            (j, u) = run_from(pts, i, m, &pl, eps);
        }
        if j == i {
            v = pts[i];
            count += 1;
            i += 1;
            continue;
        }
        if j >= n {
            return count + 1;
        }
        let t = far_foot(pts, i, j, &pl, u);
        let g = [0, 1, 2].map(|k| v[k] + t * (u.0 * pl.e1[k] + u.1 * pl.e2[k]));
        v = normed(g);
        count += 1;
        i = j;
    }
    count
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let t: f64 = args[1].parse().expect("T in metres");
    let share: f64 = args[2].parse().expect("EPS as a share of T");
    let text = std::fs::read_to_string(&args[3]).expect("the lines");
    let doc: serde_json::Value = serde_json::from_str(&text).expect("GeoJSON");
    let lines: Vec<Vec<V3>> = doc["features"]
        .as_array()
        .expect("features")
        .iter()
        .map(|f| {
            f["geometry"]["coordinates"]
                .as_array()
                .expect("a LineString")
                .iter()
                .map(|p| lonlat_to_unit(p[0].as_f64().unwrap(), p[1].as_f64().unwrap()))
                .collect()
        })
        .collect();
    let eps = share * t / EARTH_RADIUS_M;
    let points: usize = lines.iter().map(Vec::len).sum();
    let start = Instant::now();
    let vertices: usize = lines.iter().map(|l| greedy(l, eps)).sum();
    let took = start.elapsed();
    println!(
        "T = {t} m, EPS = {share} T: {} lines, {points} points; greedy vertices {vertices} \
         (~{} numbers); {:.1} ms on one thread",
        lines.len(),
        2 * vertices + lines.len(),
        took.as_secs_f64() * 1e3
    );
}
