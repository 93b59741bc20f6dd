//! `GET /processes` and `GET /processes/{id}`: the three GeoJSON operations as OGC processes.
//! Their option inputs are generated from the options' one home
//! ([`OperationKind::option_names`] and [`RawOptions::option_type`]); ranges and the rules
//! between options are not repeated in the schemas but checked by [`crate::earth::into_job`]
//! when a process runs (a 422 naming the input).

use crate::earth::job::{OperationKind, OptionType, RawOptions};
use crate::service::error::ApiError;
use crate::service::handlers::{GEO_JSON, JSON};
use crate::service::ogc::{base_url, json_response, link};
use crate::service::query::GeoEndpoint;
use crate::service::AppState;
use axum::extract::{Path, State};
use axum::http::{HeaderMap, StatusCode};
use axum::response::Response;
use serde_json::{json, Map, Value};

/// The processes, by id.
pub(crate) const PROCESSES: [(&str, GeoEndpoint); 3] = [
    ("fit", GeoEndpoint::Fit),
    ("interpolate", GeoEndpoint::Interpolate),
    ("evaluate", GeoEndpoint::Evaluate),
];

/// The process `id`.
///
/// # Errors
/// 404 naming the processes there are.
pub(crate) fn process(id: &str) -> Result<GeoEndpoint, ApiError> {
    PROCESSES
        .iter()
        .find(|(n, _)| *n == id)
        .map(|(_, e)| *e)
        .ok_or_else(|| {
            let mut e = ApiError::not_found(&format!("/processes/{id}"));
            e.detail =
                format!("no process {id:?}: the processes are fit, interpolate and evaluate");
            e
        })
}

fn description_of(kind: OperationKind) -> &'static str {
    match kind {
        OperationKind::Fit => "Fits a smooth spherical B-spline to every LineString and Polygon ring of a GeoJSON document (as POST /v1/fit): to a tolerance in metres, or with a given number of control points; per feature or as a shared coverage",
        OperationKind::Interpolate => "Beta-splines through every vertex of every line and ring (as POST /v1/interpolate)",
        OperationKind::Evaluate => "Evaluates the splines in properties.fit or properties.interpolation of a fit's or an interpolation's output (as POST /v1/evaluate), for instance a previous job's result by reference",
    }
}

/// The JSON schema of one option's value.
pub(crate) fn option_schema(t: OptionType) -> Value {
    match t {
        OptionType::Integer => json!({"type": "integer", "minimum": 0}),
        OptionType::Number => json!({"type": "number"}),
        OptionType::Boolean => json!({"type": "boolean"}),
        OptionType::Text => json!({"type": "string", "minLength": 1}),
        OptionType::OneOf(names) => json!({"type": "string", "enum": names}),
    }
}

/// The `data` input: a GeoJSON object by value, or a reference to a job's result here.
fn data_input() -> Value {
    json!({
        "title": "GeoJSON input",
        "description": "A GeoJSON object (FeatureCollection, Feature or geometry) by value, or {\"href\": \"…/jobs/{jobId}/results\"}: the result of a successful job of this server (no other URL is fetched)",
        "minOccurs": 1,
        "maxOccurs": 1,
        "schema": {
            "oneOf": [
                {"type": "object", "contentMediaType": GEO_JSON, "required": ["type"]},
                {"type": "object", "required": ["href"], "properties": {"href": {"type": "string", "format": "uri-reference"}}}
            ]
        }
    })
}

/// The process summary (in `/processes`) of `id`.
fn summary(base: &str, id: &str, kind: OperationKind) -> Value {
    json!({
        "id": id,
        "title": id,
        "description": description_of(kind),
        "version": env!("CARGO_PKG_VERSION"),
        "jobControlOptions": ["sync-execute", "async-execute", "dismiss"],
        "outputTransmission": ["value"],
        "links": [
            link(format!("{base}/processes/{id}"), "self", JSON, "process description"),
            link(format!("{base}/processes/{id}"), "http://www.opengis.net/def/rel/ogc/1.0/process-desc", JSON, "process description"),
            link(format!("{base}/processes/{id}/execution"), "http://www.opengis.net/def/rel/ogc/1.0/execute", JSON, "execute"),
        ],
    })
}

/// The full description of process `id`: the summary, the inputs (`data` and one per option)
/// and the output `result`.
pub(crate) fn description(base: &str, id: &str, kind: OperationKind) -> Value {
    let mut inputs = Map::new();
    inputs.insert("data".into(), data_input());
    for name in kind.option_names() {
        let Some(t) = RawOptions::option_type(name) else {
            continue; // every option has a type (a unit test in earth::job says so)
        };
        inputs.insert(
            (*name).into(),
            json!({
                "title": name,
                "description": format!("as the query parameter {name} of POST /v1/{} (see /openapi.yaml)", kind.name()),
                "minOccurs": 0,
                "maxOccurs": 1,
                "schema": option_schema(t),
            }),
        );
    }
    let mut d = summary(base, id, kind);
    d["inputs"] = Value::Object(inputs);
    d["outputs"] = json!({
        "result": {
            "title": "result",
            "description": "the output document, as the /v1 endpoint answers it: GeoJSON, or TopoJSON with topology=shared and format=topojson",
            "schema": {"type": "object", "contentMediaType": GEO_JSON}
        }
    });
    d
}

pub(super) async fn list(State(_): State<AppState>, headers: HeaderMap) -> Response {
    let b = base_url(&headers);
    let processes: Vec<Value> = PROCESSES
        .iter()
        .map(|(id, e)| summary(&b, id, e.kind()))
        .collect();
    let body = json!({
        "processes": processes,
        "links": [link(format!("{b}/processes"), "self", JSON, "processes")],
    });
    json_response(StatusCode::OK, &body, JSON)
}

pub(super) async fn describe(
    State(_): State<AppState>,
    Path(id): Path<String>,
    headers: HeaderMap,
) -> Result<Response, ApiError> {
    let kind = process(&id)?.kind();
    Ok(json_response(
        StatusCode::OK,
        &description(&base_url(&headers), &id, kind),
        JSON,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every option of every operation is an input, typed as `RawOptions::set` reads it.
    #[test]
    fn inputs_are_the_options_of_the_operation() {
        for (id, e) in PROCESSES {
            let d = description("http://h", id, e.kind());
            let inputs = d["inputs"].as_object().unwrap();
            assert_eq!(inputs.len(), e.kind().option_names().len() + 1, "{id}");
            for name in e.kind().option_names() {
                assert!(inputs[*name]["schema"]["type"].is_string(), "{id} {name}");
            }
        }
        let fit = description("http://h", "fit", OperationKind::Fit);
        assert_eq!(fit["inputs"]["tolerance_m"]["schema"]["type"], "number");
        assert_eq!(fit["inputs"]["degree"]["schema"]["type"], "integer");
        assert_eq!(
            fit["inputs"]["topology"]["schema"]["enum"],
            json!(["per-feature", "shared"])
        );
        assert!(process("nope").is_err());
    }
}
