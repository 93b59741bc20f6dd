// Natural Earth 10m land outlines (npm world-atlas land-10m.json) as a GeoJSON FeatureCollection
// with one Polygon feature per land polygon, for python/bench/land.sh.
// Usage: node land_geojson.mjs NODE_MODULES_DIR > land-10m.geojson
import { createRequire } from "node:module";
import path from "node:path";

const modules = process.argv[2];
const require = createRequire(path.join(path.resolve(modules), "x.js"));
const topojson = require("topojson-client");
const topo = require("world-atlas/land-10m.json");
const land = topojson.feature(topo, topo.objects.land);
const features = [];
for (const f of land.features) {
  const g = f.geometry;
  const polys = g.type === "MultiPolygon" ? g.coordinates : [g.coordinates];
  for (const rings of polys) {
    features.push({
      type: "Feature",
      properties: { polygon: features.length },
      geometry: { type: "Polygon", coordinates: rings },
    });
  }
}
process.stdout.write(JSON.stringify({ type: "FeatureCollection", features }));
