//! OGC API – Features over the job store: each successful job with a GeoJSON result is a
//! collection named by its job id, so GIS tools open results with no plugin
//! (`ogrinfo OAPIF:http://host/`, QGIS's "WFS / OGC API – Features" source).
//!
//! A feature's id is its own `id` when the result carries one, else its index in the result.
//! Paging is `limit` (1 to [`MAX_LIMIT`], default [`DEFAULT_LIMIT`]) and `offset`, with `next`
//! and `prev` links; `bbox` (`minLon,minLat,maxLon,maxLat`, `minLon > maxLon` across the
//! antimeridian) keeps the features whose coordinates' box meets it (`minLat > maxLat` meets
//! nothing). The parsed result of the
//! last collection read is kept ([`CACHE`]) so that paging through it does not parse it again.

use crate::service::auth::Owner;
use crate::service::error::ApiError;
use crate::service::handlers::{parse_json, respond, GEO_JSON, JSON};
use crate::service::ogc::jobs::{find, result_bytes};
use crate::service::ogc::store::{JobRecord, Status};
use crate::service::ogc::{base_url, json_response, link};
use crate::service::query::Params;
use crate::service::AppState;
use axum::extract::{Extension, Path, Query, State};
use axum::http::{HeaderMap, StatusCode};
use axum::response::Response;
use serde_json::{json, Value};
use std::sync::{Arc, Mutex};

/// Features per page when the client gives no `limit`.
pub(crate) const DEFAULT_LIMIT: usize = 100;
/// Most features per page.
pub(crate) const MAX_LIMIT: usize = 10_000;

const CRS84: &str = "http://www.opengis.net/def/crs/OGC/1.3/CRS84";

/// The features of the last collection read, by job id (one entry: jobs are read one at a time
/// by a GIS client paging through them; a result is immutable once written).
static CACHE: Mutex<Option<(String, Arc<Vec<Value>>)>> = Mutex::new(None);

fn is_collection(r: &JobRecord) -> bool {
    r.status == Status::Successful && r.media_type.as_deref() == Some(GEO_JSON)
}

fn collection_info(base: &str, r: &JobRecord) -> Value {
    let id = &r.id;
    json!({
        "id": id,
        "title": format!("{} job {id}", r.process),
        "description": format!("the result of the {} job {id}: {} curves from {} input positions", r.process, r.curves, r.input_points),
        "itemType": "feature",
        "crs": [CRS84],
        "extent": {"spatial": {"bbox": [[-180.0, -90.0, 180.0, 90.0]], "crs": CRS84}},
        "links": [
            link(format!("{base}/collections/{id}"), "self", JSON, "this collection"),
            link(format!("{base}/collections/{id}/items"), "items", GEO_JSON, "the features"),
            link(format!("{base}/jobs/{id}"), "related", JSON, "the job"),
        ],
    })
}

fn no_collection(id: &str) -> ApiError {
    let mut e = ApiError::not_found(&format!("/collections/{id}"));
    e.detail = format!(
        "no collection {id:?}: collections are the successful jobs with a GeoJSON result (see /collections)"
    );
    e
}

/// `owner`'s job behind collection `id`.
async fn collection_job(state: &AppState, owner: &Owner, id: &str) -> Result<JobRecord, ApiError> {
    match find(state, owner, id).await {
        Ok(r) if is_collection(&r) => Ok(r),
        Err(e) if e.slug == "store-unavailable" => Err(e),
        _ => Err(no_collection(id)),
    }
}

pub(super) async fn collections(
    State(state): State<AppState>,
    Extension(owner): Extension<Owner>,
    headers: HeaderMap,
) -> Result<Response, ApiError> {
    let b = base_url(&headers);
    let list: Vec<Value> = state
        .jobs
        .list(&owner)
        .await?
        .iter()
        .filter(|r| is_collection(r))
        .map(|r| collection_info(&b, r))
        .collect();
    let body = json!({
        "collections": list,
        "links": [link(format!("{b}/collections"), "self", JSON, "collections")],
    });
    Ok(json_response(StatusCode::OK, &body, JSON))
}

pub(super) async fn collection(
    State(state): State<AppState>,
    Extension(owner): Extension<Owner>,
    Path(id): Path<String>,
    headers: HeaderMap,
) -> Result<Response, ApiError> {
    let r = collection_job(&state, &owner, &id).await?;
    Ok(json_response(
        StatusCode::OK,
        &collection_info(&base_url(&headers), &r),
        JSON,
    ))
}

/// The features of collection `id` (parsed off the async workers, or from [`CACHE`]).
async fn features_of(
    state: &AppState,
    owner: &Owner,
    id: &str,
) -> Result<Arc<Vec<Value>>, ApiError> {
    collection_job(state, owner, id).await?;
    if let Some((cached, f)) = CACHE.lock().unwrap_or_else(|p| p.into_inner()).as_ref() {
        if cached == id {
            return Ok(f.clone());
        }
    }
    let (bytes, _) = result_bytes(state, owner, id).await?;
    let features = tokio::task::spawn_blocking(move || -> Result<Vec<Value>, ApiError> {
        let v = parse_json(&bytes).map_err(|_| ApiError::internal())?;
        Ok(match v {
            Value::Object(mut o) => match o.remove("features") {
                Some(Value::Array(a)) => a,
                _ => vec![Value::Object(o)],
            },
            _ => Vec::new(),
        })
    })
    .await
    .map_err(|_| ApiError::internal())??;
    let features = Arc::new(features);
    *CACHE.lock().unwrap_or_else(|p| p.into_inner()) = Some((id.to_string(), features.clone()));
    Ok(features)
}

/// The id of feature `i`: its own, else its index.
fn feature_id(f: &Value, i: usize) -> String {
    match f.get("id") {
        Some(Value::String(s)) => s.clone(),
        Some(Value::Number(n)) => n.to_string(),
        _ => i.to_string(),
    }
}

/// `f` with its id set (as [`feature_id`]), and a link to itself when `base` is given.
fn with_id(f: &Value, i: usize) -> Value {
    let mut f = f.clone();
    if f.get("id").is_none() {
        if let Value::Object(o) = &mut f {
            o.insert("id".into(), json!(i));
        }
    }
    f
}

/// The box (`[min_lon, min_lat, max_lon, max_lat]`) of all positions under `v`.
fn extend_box(v: &Value, b: &mut [f64; 4]) {
    if let Value::Array(a) = v {
        if let (Some(lon), Some(lat)) = (
            a.first().and_then(Value::as_f64),
            a.get(1).and_then(Value::as_f64),
        ) {
            b[0] = b[0].min(lon);
            b[1] = b[1].min(lat);
            b[2] = b[2].max(lon);
            b[3] = b[3].max(lat);
        } else {
            for x in a {
                extend_box(x, b);
            }
        }
    }
}

fn geometry_box(g: &Value, b: &mut [f64; 4]) {
    if let Some(c) = g.get("coordinates") {
        extend_box(c, b);
    }
    if let Some(Value::Array(gs)) = g.get("geometries") {
        for g in gs {
            geometry_box(g, b);
        }
    }
}

/// Whether feature `f` meets the query box `q` (module docs).
fn meets(f: &Value, q: &[f64; 4]) -> bool {
    let mut b = [
        f64::INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NEG_INFINITY,
    ];
    if let Some(g) = f.get("geometry") {
        geometry_box(g, &mut b);
    }
    if b[0] > b[2] {
        return false; // no positions
    }
    let lat = b[1] <= q[3] && b[3] >= q[1];
    let lon = if q[0] <= q[2] {
        b[0] <= q[2] && b[2] >= q[0]
    } else {
        b[2] >= q[0] || b[0] <= q[2]
    };
    lat && lon
}

/// `bbox`: four numbers, or six (heights ignored).
fn parse_bbox(s: &str) -> Result<[f64; 4], ApiError> {
    let bad = |why: &str| {
        ApiError::invalid_query(
            "bbox",
            format!("bbox={s:?} {why}: give minLon,minLat,maxLon,maxLat in degrees"),
        )
    };
    let n: Vec<f64> = s
        .split(',')
        .map(|x| crate::earth::parse_json_number(x.trim()))
        .collect::<Option<_>>()
        .ok_or_else(|| bad("is not numbers"))?;
    let b = match n.len() {
        4 => [n[0], n[1], n[2], n[3]],
        6 => [n[0], n[1], n[3], n[4]],
        _ => return Err(bad("does not have 4 (or 6) numbers")),
    };
    // Values are compared as given: a box with minLat > maxLat, or beyond the Earth, meets
    // nothing (or everything), rather than being refused, so that any four numbers the contract
    // allows are a query with an answer.
    Ok(b)
}

pub(super) async fn items(
    State(state): State<AppState>,
    Extension(owner): Extension<Owner>,
    Path(id): Path<String>,
    Query(pairs): Query<Vec<(String, String)>>,
    headers: HeaderMap,
) -> Result<Response, ApiError> {
    // `datetime` (Features core) is accepted and matches every feature: results carry no times
    // of their own that the collection describes.
    let p = Params::new(pairs, &["limit", "offset", "bbox", "datetime", "f"])?;
    if let Some(f) = p.get::<String>("f", "a format")? {
        if f != "json" && f != "geojson" {
            return Err(ApiError::invalid_query(
                "f",
                format!("f={f:?}: only json is served"),
            ));
        }
    }
    let limit = p.int("limit")?.unwrap_or(DEFAULT_LIMIT);
    if !(1..=MAX_LIMIT).contains(&limit) {
        return Err(ApiError::invalid_query(
            "limit",
            format!("limit={limit}: give 1 to {MAX_LIMIT}"),
        ));
    }
    let offset = p.int("offset")?.unwrap_or(0);
    let bbox_text = p.get::<String>("bbox", "a box")?;
    let bbox = bbox_text.as_deref().map(parse_bbox).transpose()?;
    let features = features_of(&state, &owner, &id).await?;
    let matched: Vec<(usize, &Value)> = features
        .iter()
        .enumerate()
        .filter(|(_, f)| bbox.as_ref().is_none_or(|q| meets(f, q)))
        .collect();
    let page: Vec<Value> = matched
        .iter()
        .skip(offset)
        .take(limit)
        .map(|(i, f)| with_id(f, *i))
        .collect();
    let b = base_url(&headers);
    let url = |offset: usize| {
        let mut u = format!("{b}/collections/{id}/items?limit={limit}&offset={offset}");
        if let Some(t) = &bbox_text {
            u.push_str("&bbox=");
            u.push_str(t);
        }
        u
    };
    let mut links = vec![
        link(url(offset), "self", GEO_JSON, "this page"),
        link(
            format!("{b}/collections/{id}"),
            "collection",
            JSON,
            "the collection",
        ),
    ];
    if offset.saturating_add(page.len()) < matched.len() {
        links.push(link(
            url(offset + page.len()),
            "next",
            GEO_JSON,
            "next page",
        ));
    }
    if offset > 0 {
        links.push(link(
            url(offset.saturating_sub(limit)),
            "prev",
            GEO_JSON,
            "previous page",
        ));
    }
    let body = json!({
        "type": "FeatureCollection",
        "numberMatched": matched.len(),
        "numberReturned": page.len(),
        "features": page,
        "links": links,
    });
    Ok(respond(
        GEO_JSON,
        serde_json::to_vec(&body).map_err(|_| ApiError::internal())?,
    ))
}

pub(super) async fn item(
    State(state): State<AppState>,
    Extension(owner): Extension<Owner>,
    Path((id, feature)): Path<(String, String)>,
    headers: HeaderMap,
) -> Result<Response, ApiError> {
    let features = features_of(&state, &owner, &id).await?;
    let (i, f) = features
        .iter()
        .enumerate()
        .find(|(i, f)| feature_id(f, *i) == feature)
        .ok_or_else(|| {
            let mut e = ApiError::not_found(&format!("/collections/{id}/items/{feature}"));
            e.detail = format!("collection {id} has no feature {feature:?}");
            e
        })?;
    let b = base_url(&headers);
    let mut f = with_id(f, i);
    f["links"] = json!([
        link(
            format!("{b}/collections/{id}/items/{feature}"),
            "self",
            GEO_JSON,
            "this feature"
        ),
        link(
            format!("{b}/collections/{id}"),
            "collection",
            JSON,
            "the collection"
        ),
    ]);
    Ok(respond(
        GEO_JSON,
        serde_json::to_vec(&f).map_err(|_| ApiError::internal())?,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn line(coords: Value) -> Value {
        json!({"type": "Feature", "properties": {}, "geometry": {"type": "LineString", "coordinates": coords}})
    }

    #[test]
    fn bbox_meets_features_and_wraps_the_antimeridian() {
        let f = line(json!([[170.0, 10.0], [179.0, 12.0]]));
        assert!(meets(&f, &parse_bbox("160,0,175,20").unwrap()));
        assert!(!meets(&f, &parse_bbox("0,0,10,20").unwrap()));
        assert!(!meets(&f, &parse_bbox("160,30,175,40").unwrap()));
        assert!(
            meets(&f, &parse_bbox("175,0,-170,20").unwrap()),
            "across 180"
        );
        assert!(!meets(&f, &parse_bbox("179.5,0,-170,20").unwrap()));
        assert!(
            meets(&f, &parse_bbox("160,0,0,175,20,100").unwrap()),
            "6 numbers"
        );
        assert!(!meets(
            &json!({"type": "Feature", "geometry": null}),
            &parse_bbox("-180,-90,180,90").unwrap()
        ));
        assert!(
            !meets(&f, &parse_bbox("160,20,175,0").unwrap()),
            "minLat > maxLat"
        );
        for bad in ["1,2,3", "a,b,c,d", "1,2,3,4,5", "NaN,0,1,1"] {
            assert_eq!(parse_bbox(bad).unwrap_err().status.as_u16(), 400, "{bad}");
        }
    }

    #[test]
    fn ids_are_the_features_own_or_their_index() {
        assert_eq!(feature_id(&json!({"id": "a"}), 3), "a");
        assert_eq!(feature_id(&json!({"id": 7}), 3), "7");
        assert_eq!(feature_id(&json!({}), 3), "3");
        assert_eq!(with_id(&json!({}), 3)["id"], 3);
    }
}
