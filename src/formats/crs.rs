//! The CRS a file's coordinates are in, and their transformation to lon/lat.
//!
//! EPSG:4326, CRS84 and EPSG:4979 (and a file that states no CRS: GeoJSON's convention) are
//! lon/lat already and pass unchanged. Any other CRS known by an EPSG code is transformed with
//! `proj4rs` (pure Rust) from the definition `crs-definitions` gives for the code (Web
//! Mercator, UTM and most national grids); a CRS with no code, or one `proj4rs` cannot
//! transform (a datum shift needing a grid file), is refused with an error naming it. Never a
//! silent guess.
//!
//! A `.prj` written by GDAL's Shapefile driver holds ESRI WKT, which names no authority: the
//! CRS is then found by its name (`GCS_WGS_1984`, `WGS_1984_Web_Mercator_Auxiliary_Sphere`,
//! `WGS_1984_UTM_Zone_33N`, or a name equal to an EPSG definition's once case and punctuation
//! are set aside).

use proj4rs::transform::{transform, Transform, TransformClosure};
use proj4rs::Proj;
use serde_json::Value;
use std::sync::Arc;

/// The CRS of a layer.
#[derive(Clone)]
pub struct Crs {
    /// How the CRS is named in messages: `EPSG:3857`, `EPSG:4326`, `none stated`.
    pub name: String,
    /// The projection to undo, `None` for lon/lat.
    from: Option<Arc<Proj>>,
}

impl std::fmt::Debug for Crs {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Crs")
            .field("name", &self.name)
            .field("transformed", &self.from.is_some())
            .finish()
    }
}

/// EPSG codes of lon/lat on WGS 84 (2-D and 3-D).
const LONLAT_CODES: [i64; 2] = [4326, 4979];

impl Crs {
    /// Lon/lat on WGS 84, as stated by `name`.
    pub fn lonlat(name: &str) -> Crs {
        Crs {
            name: name.to_string(),
            from: None,
        }
    }

    /// No CRS stated: the coordinates are taken as lon/lat (GeoJSON's convention); coordinates
    /// out of range are then refused where they are checked.
    pub fn unstated() -> Crs {
        Crs::lonlat("none stated (taken as lon/lat)")
    }

    /// True when the coordinates pass unchanged.
    pub fn is_lonlat(&self) -> bool {
        self.from.is_none()
    }

    /// The CRS of EPSG code `code`.
    ///
    /// # Errors
    /// The code is unknown, or its definition cannot be transformed by `proj4rs`.
    pub fn from_epsg(code: i64) -> Result<Crs, String> {
        if LONLAT_CODES.contains(&code) {
            return Ok(Crs::lonlat(&format!("EPSG:{code}")));
        }
        let def = u16::try_from(code)
            .ok()
            .and_then(crs_definitions::from_code)
            .ok_or_else(|| {
                format!("the CRS EPSG:{code} is not one this build knows; give the data in EPSG:4326 (e.g. `ogr2ogr -t_srs EPSG:4326`)")
            })?;
        Crs::from_proj_string(&format!("EPSG:{code}"), def.proj4)
    }

    /// The CRS of a PROJ string, named `name`.
    fn from_proj_string(name: &str, proj4: &str) -> Result<Crs, String> {
        let proj = Proj::from_proj_string(proj4).map_err(|e| {
            format!("the CRS {name} ({proj4}) cannot be transformed here: {e}; give the data in EPSG:4326")
        })?;
        if proj.is_latlong() && is_wgs84_lonlat(proj4) {
            return Ok(Crs::lonlat(name));
        }
        if proj.is_geocent() {
            return Err(format!(
                "the CRS {name} is geocentric (x, y, z), not a map: give the data in EPSG:4326"
            ));
        }
        Ok(Crs {
            name: name.to_string(),
            from: Some(Arc::new(proj)),
        })
    }

    /// The CRS of OGC or ESRI WKT (a `.prj`, a GeoPackage definition).
    ///
    /// # Errors
    /// No EPSG code can be found for it, or it cannot be transformed.
    pub fn from_wkt(wkt: &str) -> Result<Crs, String> {
        let wkt = wkt.trim();
        if let Some(code) = outer_authority(wkt) {
            return Crs::from_epsg(code);
        }
        let name = wkt_name(wkt).unwrap_or_default();
        if let Some(code) = code_of_name(&name, wkt) {
            return Crs::from_epsg(code);
        }
        Err(format!(
            "the CRS {:?} names no EPSG code this build knows; give the data in EPSG:4326 (e.g. `ogr2ogr -t_srs EPSG:4326`)",
            if name.is_empty() { wkt } else { &name }
        ))
    }

    /// Transforms the positions of a GeoJSON geometry to lon/lat in place (a third number, an
    /// altitude, is kept as it is).
    ///
    /// # Errors
    /// A position that is not two numbers, or that the projection cannot undo (outside its
    /// domain).
    pub fn to_lonlat(&self, geometry: &mut Value) -> Result<(), String> {
        let Some(from) = &self.from else {
            return Ok(());
        };
        let to = wgs84();
        walk_positions(geometry, &mut |p| {
            let (Some(x), Some(y)) = (p[0].as_f64(), p[1].as_f64()) else {
                return Err("a position is not two numbers".to_string());
            };
            let mut pt = Point(x, y);
            if from.is_latlong() {
                pt = Point(x.to_radians(), y.to_radians());
            }
            transform(from, to, &mut pt).map_err(|e| {
                format!(
                    "the position [{x}, {y}] cannot be transformed from {}: {e}",
                    self.name
                )
            })?;
            let (lon, lat) = (pt.0.to_degrees(), pt.1.to_degrees());
            if !(lon.is_finite() && lat.is_finite()) {
                return Err(format!(
                    "the position [{x}, {y}] is outside the area of {}",
                    self.name
                ));
            }
            p[0] = super::number(lon);
            p[1] = super::number(lat);
            Ok(())
        })
    }
}

/// True for a PROJ string of lon/lat on WGS 84 (no datum shift, Greenwich).
fn is_wgs84_lonlat(proj4: &str) -> bool {
    let no_shift = !proj4.contains("+towgs84=")
        || proj4.contains("+towgs84=0,0,0,0,0,0,0")
        || proj4.contains("+towgs84=0,0,0 ");
    (proj4.contains("+datum=WGS84") || proj4.contains("+ellps=WGS84"))
        && !proj4.contains("+pm=")
        && no_shift
}

/// The lon/lat target (built once).
fn wgs84() -> &'static Proj {
    static TO: std::sync::OnceLock<Proj> = std::sync::OnceLock::new();
    TO.get_or_init(|| {
        Proj::from_proj_string("+proj=longlat +datum=WGS84 +no_defs")
            .unwrap_or_else(|e| unreachable!("a constant PROJ string: {e}"))
    })
}

/// One position for `proj4rs`.
struct Point(f64, f64);

impl Transform for Point {
    fn transform_coordinates<F: TransformClosure>(
        &mut self,
        f: &mut F,
    ) -> proj4rs::errors::Result<()> {
        let (x, y, _) = f(self.0, self.1, 0.0)?;
        self.0 = x;
        self.1 = y;
        Ok(())
    }
}

/// Calls `f` on every position (an array of at least two values) of a GeoJSON geometry.
fn walk_positions(
    g: &mut Value,
    f: &mut dyn FnMut(&mut Vec<Value>) -> Result<(), String>,
) -> Result<(), String> {
    let Some(obj) = g.as_object_mut() else {
        return Ok(());
    };
    if let Some(Value::Array(members)) = obj.get_mut("geometries") {
        for m in members {
            walk_positions(m, f)?;
        }
        return Ok(());
    }
    match obj.get_mut("coordinates") {
        Some(c) => walk_array(c, f),
        None => Ok(()),
    }
}

fn walk_array(
    v: &mut Value,
    f: &mut dyn FnMut(&mut Vec<Value>) -> Result<(), String>,
) -> Result<(), String> {
    let Value::Array(items) = v else {
        return Ok(());
    };
    if items.first().is_some_and(Value::is_number) {
        if items.len() < 2 {
            return Err("a position has fewer than two numbers".into());
        }
        return f(items);
    }
    for item in items {
        walk_array(item, f)?;
    }
    Ok(())
}

/// The EPSG code of the outermost `AUTHORITY["EPSG", "code"]` (WKT1) or `ID["EPSG", code]`
/// (WKT2) of `wkt`: the one at nesting depth 1, which names the whole CRS.
fn outer_authority(wkt: &str) -> Option<i64> {
    let bytes = wkt.as_bytes();
    let mut depth = 0i32;
    let mut found = None;
    let mut i = 0;
    let mut in_string = false;
    while i < bytes.len() {
        let b = bytes[i];
        if in_string {
            in_string = b != b'"';
        } else if b == b'"' {
            in_string = true;
        } else if b == b'[' || b == b'(' {
            depth += 1;
        } else if b == b']' || b == b')' {
            depth -= 1;
        } else if depth == 1 {
            let rest = &wkt[i..];
            let tag = ["AUTHORITY[", "ID["]
                .into_iter()
                .find(|t| rest.len() >= t.len() && rest[..t.len()].eq_ignore_ascii_case(t));
            if let Some(tag) = tag {
                let inner = &rest[tag.len()..];
                let end = inner.find(']').unwrap_or(inner.len());
                let parts: Vec<&str> = inner[..end]
                    .split(',')
                    .map(|s| s.trim().trim_matches('"'))
                    .collect();
                if parts.len() >= 2 && parts[0].eq_ignore_ascii_case("EPSG") {
                    found = parts[1].parse().ok();
                }
            }
        }
        i += 1;
    }
    found
}

/// The name of the CRS of `wkt`: the first quoted string.
fn wkt_name(wkt: &str) -> Option<String> {
    let start = wkt.find('"')? + 1;
    let len = wkt[start..].find('"')?;
    Some(wkt[start..start + len].to_string())
}

/// Lower case, letters and digits only.
fn normalised(name: &str) -> String {
    name.chars()
        .filter(char::is_ascii_alphanumeric)
        .map(|c| c.to_ascii_lowercase())
        .collect()
}

/// The EPSG code of a CRS named in ESRI WKT.
fn code_of_name(name: &str, wkt: &str) -> Option<i64> {
    let n = normalised(name);
    let projected = wkt.trim_start().to_ascii_uppercase().starts_with("PROJCS");
    if !projected && matches!(n.as_str(), "gcswgs1984" | "wgs84" | "wgs1984") {
        return Some(4326);
    }
    if matches!(
        n.as_str(),
        "wgs1984webmercatorauxiliarysphere" | "wgs84pseudomercator" | "wgs1984webmercator"
    ) {
        return Some(3857);
    }
    if let Some(zone) = n
        .strip_prefix("wgs1984utmzone")
        .or_else(|| n.strip_prefix("wgs84utmzone"))
    {
        let (digits, hemisphere) = zone.split_at(zone.len().saturating_sub(1));
        let z: i64 = digits.parse().ok()?;
        if (1..=60).contains(&z) {
            return match hemisphere {
                "n" => Some(32600 + z),
                "s" => Some(32700 + z),
                _ => None,
            };
        }
    }
    // A name equal to an EPSG definition's, case and punctuation set aside.
    (1..=u16::MAX).find_map(|code| {
        let def = crs_definitions::from_code(code)?;
        let other = wkt_name(def.wkt)?;
        (normalised(&other) == n).then_some(i64::from(code))
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn web_mercator_and_utm_go_back_to_lonlat() {
        // Reference values from GDAL 3.6 `ogr2ogr -t_srs` (PROJ): 15.5 E, 46.2 N.
        let mut g = json!({"type": "Point", "coordinates": [1725452.10729574, 5812457.491341968]});
        Crs::from_epsg(3857).unwrap().to_lonlat(&mut g).unwrap();
        let c = &g["coordinates"];
        assert!((c[0].as_f64().unwrap() - 15.5).abs() < 1e-9, "{g}");
        assert!((c[1].as_f64().unwrap() - 46.2).abs() < 1e-9, "{g}");
        let mut g = json!({"type": "LineString", "coordinates": [[538576.406887083, 5116390.743373507, 300.0]]});
        Crs::from_epsg(32633).unwrap().to_lonlat(&mut g).unwrap();
        let c = &g["coordinates"][0];
        assert!((c[0].as_f64().unwrap() - 15.5).abs() < 1e-8, "{g}");
        assert!((c[1].as_f64().unwrap() - 46.2).abs() < 1e-8, "{g}");
        assert_eq!(c[2], json!(300.0));
    }

    #[test]
    fn names_and_authorities_from_wkt() {
        let esri = r#"PROJCS["WGS_1984_UTM_Zone_33N",GEOGCS["GCS_WGS_1984",DATUM["D_WGS_1984",SPHEROID["WGS_1984",6378137.0,298.257223563]],PRIMEM["Greenwich",0.0],UNIT["Degree",0.0174532925199433]],PROJECTION["Transverse_Mercator"],UNIT["Meter",1.0]]"#;
        assert_eq!(Crs::from_wkt(esri).unwrap().name, "EPSG:32633");
        let gcs = r#"GEOGCS["GCS_WGS_1984",DATUM["D_WGS_1984",SPHEROID["WGS_1984",6378137.0,298.257223563]],PRIMEM["Greenwich",0.0],UNIT["Degree",0.0174532925199433]]"#;
        let c = Crs::from_wkt(gcs).unwrap();
        assert!(c.is_lonlat() && c.name == "EPSG:4326");
        let ogc = r#"PROJCS["WGS 84 / Pseudo-Mercator",GEOGCS["WGS 84",AUTHORITY["EPSG","4326"]],AUTHORITY["EPSG","3857"]]"#;
        assert_eq!(Crs::from_wkt(ogc).unwrap().name, "EPSG:3857");
        let unknown =
            r#"PROJCS["My_Own_Grid",GEOGCS["GCS_Mars_2000"],PROJECTION["Equirectangular"]]"#;
        let e = Crs::from_wkt(unknown).unwrap_err();
        assert!(e.contains("My_Own_Grid"), "{e}");
        assert!(Crs::from_epsg(999_999).unwrap_err().contains("EPSG:999999"));
    }
}
