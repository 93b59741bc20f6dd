//! What a polygon ring needs to come back valid: every rule about rings in one room.
//!
//! * [`antimeridian`]: lon/lat output cut at ±180 degrees (RFC 7946 §3.1.9) and rings around a
//!   pole closed along it; input cut at ±180 rejoined before fitting.
//! * [`validity`]: fitted rings and arcs judged for meetings (on the sphere and in the plane, as
//!   GeoJSON readers draw them) and refitted tighter where they meet.
//! * [`splice`]: a line refitted around its meetings only, the rest kept vertex for vertex.
//! * [`small_rings`]: rings that collapse under the tolerance, kept small and valid or dropped.
//! * [`area`]: areas of polygons on the sphere (`area_m2`, `area_change` in reports).

pub mod antimeridian;
pub mod area;
pub mod small_rings;
pub mod splice;
pub mod validity;
