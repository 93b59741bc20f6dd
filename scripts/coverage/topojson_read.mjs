#!/usr/bin/env node
// Two jobs for the coverage tests (tests/it/topology.rs), both with npm `topojson-client`
// exactly as a web map uses it (topojson.feature on the first object):
//
//   node scripts/coverage/topojson_read.mjs world-atlas countries-50m OUT.geojson
//     decodes a file of npm `world-atlas` (Natural Earth, public domain) into a GeoJSON
//     FeatureCollection; longitudes that dequantise a hair beyond ±180 are clamped to ±180;
//   node scripts/coverage/topojson_read.mjs read IN.topojson OUT.geojson
//     reads a TopoJSON file (spherefit's output) back into GeoJSON.
//
// Needs `npm ci --prefix scripts/coverage` (which .ci/run does).
import { createRequire } from 'node:module';
import { readFileSync, writeFileSync } from 'node:fs';
import { fileURLToPath } from 'node:url';
import path from 'node:path';

const here = path.dirname(fileURLToPath(import.meta.url));
const require = createRequire(path.join(here, 'package.json'));
const topojson = require('topojson-client');

const clamp = (c) =>
  typeof c[0] === 'number'
    ? [Math.max(-180, Math.min(180, c[0])), Math.max(-90, Math.min(90, c[1]))]
    : c.map(clamp);

const [mode, name, out] = process.argv.slice(2);
let fc;
if (mode === 'world-atlas') {
  const topo = require(`world-atlas/${name}.json`);
  fc = topojson.feature(topo, topo.objects.countries);
  for (const f of fc.features) {
    if (f.geometry) f.geometry.coordinates = clamp(f.geometry.coordinates);
  }
  fc.source = `npm world-atlas ${require('world-atlas/package.json').version} ${name}.json, topojson-client ${require('topojson-client/package.json').version}`;
} else if (mode === 'read') {
  const topo = JSON.parse(readFileSync(name, 'utf8'));
  const key = Object.keys(topo.objects)[0];
  fc = topojson.feature(topo, topo.objects[key]);
} else {
  console.error('usage: topojson_read.mjs world-atlas NAME OUT | read IN OUT');
  process.exit(2);
}
writeFileSync(out, JSON.stringify(fc));
console.log(`${out}: ${fc.features.length} features`);
