//! Helpers shared by the integration tests: fixture access, running the binary, deterministic
//! pseudo-random numbers, unit vectors, knot vectors and known splines to sample from.

pub use spherefit::sphere::curve::bspline::clamped_uniform_knots;
use spherefit::sphere::geometry::point::{exp_map, PointSet};
use spherefit::sphere::SphericalBSpline;
use std::io::{BufRead, BufReader, Lines, Write};
use std::net::SocketAddr;
use std::process::{Child, ChildStderr, Command, Output, Stdio};

/// Mean Earth radius (IUGG), metres per radian of geodesic angle.
pub const EARTH_RADIUS_M: f64 = 6_371_008.8;

/// A fit's spline document made whole: a degree-1 spline that refers to its feature's geometry
/// (`"control_points": "geometry"`, knots left out when clamped uniform) gets `positions` (the
/// geometry's at the part's path, as written) and its knots; any other is returned as it is.
pub fn resolved_spline(
    spline: &serde_json::Value,
    positions: &serde_json::Value,
) -> serde_json::Value {
    if spline["control_points"] != "geometry" {
        return spline.clone();
    }
    let rows: Vec<serde_json::Value> = positions
        .as_array()
        .expect("positions")
        .iter()
        .map(|p| serde_json::json!([p[0], p[1]]))
        .collect();
    let mut whole = spline.clone();
    if whole.get("knots").is_none() {
        whole["knots"] = serde_json::json!(clamped_uniform_knots(rows.len(), 1));
    }
    whole["control_points"] = serde_json::Value::Array(rows);
    whole
}

/// Absolute path of a file under `fixtures/`. Tests read data only from there.
pub fn fixture_path(name: &str) -> String {
    format!("{}/fixtures/{name}", env!("CARGO_MANIFEST_DIR"))
}

/// Runs the `spherefit` binary from the package root with `args`, feeding `stdin` if given.
///
/// Stdin is written from another thread: the child may fill its stdout pipe before it has read
/// all of its input, and a write from this thread would then wait for ever.
pub fn run_spherefit(args: &[&str], stdin: Option<&[u8]>) -> Output {
    let mut child = Command::new(env!("CARGO_BIN_EXE_spherefit"))
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(args)
        .stdin(if stdin.is_some() {
            Stdio::piped()
        } else {
            Stdio::null()
        })
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the spherefit binary runs");
    let writer = stdin.map(|bytes| {
        let mut pipe = child.stdin.take().expect("stdin is piped");
        let bytes = bytes.to_vec();
        std::thread::spawn(move || {
            // A child that exits before reading everything closes the pipe: not an error here,
            // its exit status and stderr say what happened.
            let _ = pipe.write_all(&bytes);
        })
    });
    let out = child
        .wait_with_output()
        .expect("the spherefit binary finishes");
    if let Some(w) = writer {
        w.join().expect("the stdin writer does not panic");
    }
    out
}

/// The JSON value in `fixtures/<name>`.
pub fn read_fixture_json(name: &str) -> serde_json::Value {
    let path = fixture_path(name);
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{path}: {e}"))
}

/// SplitMix64: a tiny deterministic generator, so test data is the same on every run and
/// platform without a `rand` dependency.
pub struct SplitMix64(pub u64);

impl SplitMix64 {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Standard normal (Box–Muller).
    pub fn normal(&mut self) -> f64 {
        let u1 = self.uniform().max(1e-300);
        let u2 = self.uniform();
        (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
    }

    /// A uniformly distributed unit vector in R^dim.
    pub fn unit_vector(&mut self, dim: usize) -> Vec<f64> {
        loop {
            let v: Vec<f64> = (0..dim).map(|_| self.normal()).collect();
            if norm(&v) > 1e-6 {
                return unit(&v);
            }
        }
    }

    /// A random tangent vector at `base` of length `len`.
    pub fn tangent(&mut self, base: &[f64], len: f64) -> Vec<f64> {
        loop {
            let v: Vec<f64> = (0..base.len()).map(|_| self.normal()).collect();
            let t = project_out(&v, base);
            let n = norm(&t);
            if n > 1e-6 {
                return t.iter().map(|x| x * len / n).collect();
            }
        }
    }
}

pub fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

pub fn norm(a: &[f64]) -> f64 {
    dot(a, a).sqrt()
}

pub fn unit(a: &[f64]) -> Vec<f64> {
    let n = norm(a);
    a.iter().map(|x| x / n).collect()
}

/// `v` minus its component along the unit vector `base`.
pub fn project_out(v: &[f64], base: &[f64]) -> Vec<f64> {
    let along = dot(v, base);
    v.iter().zip(base).map(|(x, b)| x - along * b).collect()
}

/// Euclidean distance between two vectors.
pub fn distance(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y) * (x - y))
        .sum::<f64>()
        .sqrt()
}

/// Geodesic angle between unit vectors, written independently of the library (atan2 form).
pub fn angle(a: &[f64], b: &[f64]) -> f64 {
    let m: f64 = a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum();
    let p: f64 = a.iter().zip(b).map(|(x, y)| (x + y) * (x + y)).sum();
    2.0 * m.sqrt().atan2(p.sqrt())
}

/// Largest `| |v| - 1 |` over a set of points.
pub fn max_norm_deviation(points: &PointSet) -> f64 {
    points
        .iter()
        .map(|v| (norm(v) - 1.0).abs())
        .fold(0.0, f64::max)
}

/// A random walk of `n` unit vectors in R^dim: each step goes `step_rad` (times a factor in
/// [0.5, 1.5]) in a random direction, so neighbours are never near antipodal.
pub fn random_walk(rng: &mut SplitMix64, dim: usize, n: usize, step_rad: f64) -> Vec<Vec<f64>> {
    let mut out = vec![rng.unit_vector(dim)];
    while out.len() < n {
        let last = out.last().unwrap().clone();
        let len = step_rad * (0.5 + rng.uniform());
        let v = rng.tangent(&last, len);
        out.push(exp_map(&last, &v).unwrap());
    }
    out
}

/// A spline from rows of control points and a knot vector (panics on invalid input).
pub fn spline(degree: usize, knots: Vec<f64>, control: &[Vec<f64>]) -> SphericalBSpline {
    SphericalBSpline::try_new(degree, knots, PointSet::try_from_rows(control).unwrap()).unwrap()
}

/// Unit vector for a longitude and latitude in degrees: x = cos(lat) cos(lon),
/// y = cos(lat) sin(lon), z = sin(lat).
pub fn lonlat_to_unit(lon_deg: f64, lat_deg: f64) -> Vec<f64> {
    let (lon, lat) = (lon_deg.to_radians(), lat_deg.to_radians());
    vec![lat.cos() * lon.cos(), lat.cos() * lon.sin(), lat.sin()]
}

/// Unit vector on S^2 from longitude and latitude in radians.
pub fn sph(lon_rad: f64, lat_rad: f64) -> Vec<f64> {
    vec![
        lat_rad.cos() * lon_rad.cos(),
        lat_rad.cos() * lon_rad.sin(),
        lat_rad.sin(),
    ]
}

/// Starts `spherefit serve` on 127.0.0.1:0 with JSON logs, stopping itself after `exit_after_s`,
/// with `extra` arguments; returns the child, the address it logged and the rest of its log,
/// which the caller must keep reading (or drop) so the server never blocks on a full pipe.
pub fn spawn_server(
    exit_after_s: u32,
    extra: &[&str],
) -> (Child, SocketAddr, Lines<BufReader<ChildStderr>>) {
    let exit_after = exit_after_s.to_string();
    let mut args = vec![
        "serve",
        "--addr",
        "127.0.0.1:0",
        "--log-format",
        "json",
        "--exit-after-s",
        &exit_after,
    ];
    args.extend_from_slice(extra);
    let mut child = Command::new(env!("CARGO_BIN_EXE_spherefit"))
        .args(&args)
        .env("RUST_LOG", "warn,spherefit=info")
        .stderr(Stdio::piped())
        .stdout(Stdio::null())
        .spawn()
        .expect("spawn spherefit serve");
    let stderr = child.stderr.take().unwrap();
    let mut lines = BufReader::new(stderr).lines();
    let addr: SocketAddr = loop {
        let line = lines.next().expect("a log line").unwrap();
        let v: serde_json::Value = serde_json::from_str(&line).unwrap_or(serde_json::Value::Null);
        if let Some(a) = v["fields"]["addr"].as_str() {
            break a.parse().unwrap();
        }
    };
    (child, addr, lines)
}

/// Unit vector on S^2 for a longitude and latitude in degrees, as an array.
pub fn unit3(lon_deg: f64, lat_deg: f64) -> [f64; 3] {
    let (lon, lat) = (lon_deg.to_radians(), lat_deg.to_radians());
    [lat.cos() * lon.cos(), lat.cos() * lon.sin(), lat.sin()]
}

/// SLERP on S^2 written out from the definition: the point at fraction `f` of the minor arc
/// a-b (normalised linear interpolation below 1e-12 rad).
pub fn slerp3(a: &[f64; 3], b: &[f64; 3], f: f64) -> [f64; 3] {
    let th = angle(a, b);
    let (wa, wb) = if th < 1e-12 {
        (1.0 - f, f)
    } else {
        (((1.0 - f) * th).sin() / th.sin(), (f * th).sin() / th.sin())
    };
    let v: [f64; 3] = std::array::from_fn(|k| wa * a[k] + wb * b[k]);
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    v.map(|x| x / n)
}

/// Cross product in R^3.
pub fn cross3(a: &[f64], b: &[f64]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// Distance from q to the minor arc a-b on S^2 by the cross-track formula, written apart from
/// the library's: the great circle's pole n = a × b; q projects inside the arc when it is on
/// the inner side of both end meridians (n × a and b × n), else the nearer end counts.
pub fn distance_to_arc(q: &[f64], a: &[f64], b: &[f64]) -> f64 {
    let n = cross3(a, b);
    let len = dot(&n, &n).sqrt();
    let ends = angle(q, a).min(angle(q, b));
    if len < 1e-15 {
        return ends;
    }
    let n = [n[0] / len, n[1] / len, n[2] / len];
    let inside = dot(&cross3(&n, a), q) >= 0.0 && dot(&cross3(b, &n), q) >= 0.0;
    if inside {
        // n . (q - a), not n . q: n's direction is only known to about 1e-16 / |a - b| rad, and
        // n . a is zero only to that; against q - a (no longer than the arc for the q that
        // matter) the error stays at rounding.
        let qa = [q[0] - a[0], q[1] - a[1], q[2] - a[2]];
        dot(&n, &qa).abs().min(1.0).asin().min(ends)
    } else {
        ends
    }
}

/// Posts `body` as GeoJSON to `uri` of a fresh router with the default configuration, through
/// `oneshot`; returns the status, the content type and the body as JSON.
pub fn post_geo_oneshot(uri: &str, body: &serde_json::Value) -> (u16, String, serde_json::Value) {
    post_geo_oneshot_with(spherefit::service::ServiceConfig::default(), uri, body)
}

/// As [`post_geo_oneshot`], to a router with `config` (a whole dataset over the default body
/// limit, say).
pub fn post_geo_oneshot_with(
    config: spherefit::service::ServiceConfig,
    uri: &str,
    body: &serde_json::Value,
) -> (u16, String, serde_json::Value) {
    use axum::body::Body;
    use axum::http::{header, Request};
    use spherefit::service::{router, AppState};
    use tower::ServiceExt;
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .unwrap();
    rt.block_on(async {
        let app = router(AppState::new(config));
        let req = Request::builder()
            .method("POST")
            .uri(uri)
            .header(header::CONTENT_TYPE, "application/geo+json")
            .body(Body::from(serde_json::to_vec(body).unwrap()))
            .unwrap();
        let res = app.oneshot(req).await.unwrap();
        let status = res.status().as_u16();
        let ct = res
            .headers()
            .get(header::CONTENT_TYPE)
            .map(|v| v.to_str().unwrap().to_string())
            .unwrap_or_default();
        let bytes = axum::body::to_bytes(res.into_body(), usize::MAX)
            .await
            .unwrap();
        let v = serde_json::from_slice(&bytes)
            .unwrap_or_else(|e| panic!("not JSON ({e}): {}", String::from_utf8_lossy(&bytes)));
        (status, ct, v)
    })
}
