//! Certified geometry: proven bounds on what a curve does between samples
//! ([`bounds`]), the two-way distance between a curve and a polyline ([`two_way`]) and dense
//! sampling with a proven deviation ([`dense`]). The proofs are in
//! `docs/certified-distance.md`.

pub mod bounds;
pub mod dense;
mod polyline;
pub mod two_way;
