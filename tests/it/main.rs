//! The integration tests, one binary (one link instead of one per file): each module is one
//! area, `helpers` is what they share.

mod accelerated;
mod applications;
mod beta;
mod carry_roundtrip;
mod cli_batch;
mod cli_sphere;
mod compact_output;
mod compare_methods;
mod compression;
mod default_fit;
mod doc_paths;
mod earth;
mod formats;
mod helpers;
mod hostile;
mod hostile_props;
mod http;
mod http_openapi;
mod http_port;
mod ogc;
mod paper_reproduction;
mod seam;
mod small_rings;
mod sphere_properties;
mod time;
mod tolerance;
mod topology;
mod two_way;
mod validity;
