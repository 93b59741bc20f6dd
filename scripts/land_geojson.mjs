#!/usr/bin/env node
// Builds web/land-110m.geojson, the map page's basemap, from npm `world-atlas` (Natural Earth
// 110m land, public domain) with npm `topojson-client`. Run once after changing the recipe:
//   npm ci --prefix tests/browser && node scripts/land_geojson.mjs [OUT]
// (OUT defaults to web/land-110m.geojson; .ci/browser.sh writes elsewhere and compares.)
// Rings are cleaned on the sphere (repeats and the out-and-back spikes Natural Earth draws along
// the antimeridian dropped), oriented with land on their left (RFC 7946: exteriors
// counterclockwise, holes clockwise) and rounded to 3 decimals (about 100 m; the source is
// quantised coarser than that).
import { createRequire } from 'node:module';
import { writeFileSync } from 'node:fs';
import { fileURLToPath } from 'node:url';
import path from 'node:path';
import { toVec, toLonLat, cleanRing, orientSmallLeft } from '../web/globe.js';

const root = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '..');
const require = createRequire(path.join(root, 'tests/browser/package.json'));
const topojson = require('topojson-client');
const topo = require('world-atlas/land-110m.json');
const version = require('world-atlas/package.json').version;

const land = topojson.feature(topo, topo.objects.land);
const round = (x) => Math.round(x * 1000) / 1000;
const polygons = [];
let points = 0;
for (const f of land.features) {
  const g = f.geometry;
  const polys = g.type === 'Polygon' ? [g.coordinates] : g.coordinates;
  for (const poly of polys) {
    const rings = [];
    poly.forEach((ring, i) => {
      const vecs = cleanRing(ring.map(([lon, lat]) => toVec(lon, lat)));
      if (vecs.length < 3) return;
      let r = orientSmallLeft(vecs);
      if (i > 0) r = r.slice().reverse(); // a hole: land is outside its small side
      const ll = r.map((v) => toLonLat(v).map(round));
      ll.push(ll[0]);
      points += ll.length;
      rings.push(ll);
    });
    if (rings.length) polygons.push(rings);
  }
}
const out = {
  type: 'FeatureCollection',
  features: [
    {
      type: 'Feature',
      properties: {
        source: `Natural Earth 1:110m land (4.1.0) via npm world-atlas@${version} land-110m.json`,
        licence: 'Natural Earth: public domain',
      },
      geometry: { type: 'MultiPolygon', coordinates: polygons },
    },
  ],
};
const file = process.argv[2] || path.join(root, 'web/land-110m.geojson');
writeFileSync(file, JSON.stringify(out) + '\n');
console.log(`${file}: ${polygons.length} polygons, ${points} positions`);
