#!/usr/bin/env node
// Builds the polygon coverages the topology tests run on, from npm `us-atlas` (US Census
// cartographic boundaries, ISC) and `world-atlas` (Natural Earth, public domain), decoded with
// npm `topojson-client` exactly as published (topojson.feature), so neighbours share
// vertex-identical borders:
//   npm ci --prefix scripts/coverage && node scripts/coverage_fixture.mjs
// writes fixtures/coverage_us_states.geojson (a few western and Great Lakes states) and
// fixtures/coverage_world_110m.geojson (every country of countries-110m). Coordinates are
// written with full precision; longitudes that dequantise a hair beyond ±180 (floating point)
// are clamped to ±180, the only change.
import { createRequire } from 'node:module';
import { writeFileSync } from 'node:fs';
import { fileURLToPath } from 'node:url';
import path from 'node:path';

const root = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '..');
const require = createRequire(path.join(root, 'scripts/coverage/package.json'));
const topojson = require('topojson-client');

let clamped = 0;
const clamp = (c) => {
  if (typeof c[0] === 'number') {
    const lon = Math.max(-180, Math.min(180, c[0]));
    const lat = Math.max(-90, Math.min(90, c[1]));
    if (lon !== c[0] || lat !== c[1]) clamped++;
    return [lon, lat];
  }
  return c.map(clamp);
};

function write(name, fc, source) {
  for (const f of fc.features) f.geometry.coordinates = clamp(f.geometry.coordinates);
  const out = { type: 'FeatureCollection', source, features: fc.features };
  writeFileSync(path.join(root, 'fixtures', name), JSON.stringify(out) + '\n');
  const pts = fc.features.reduce((n, f) => n + JSON.stringify(f.geometry.coordinates).split('],[').length, 0);
  console.log(`${name}: ${fc.features.length} features, ~${pts} positions, ${clamped} clamped`);
  clamped = 0;
}

// Utah, Colorado, Arizona, New Mexico (the Four Corners), Nevada, Wyoming; Michigan (two
// peninsulas and islands), Wisconsin, Indiana, Ohio, Illinois.
const us = require('us-atlas/states-10m.json');
const keep = new Set(['49', '08', '04', '35', '32', '56', '26', '55', '18', '39', '17']);
const states = topojson.feature(us, us.objects.states);
states.features = states.features.filter((f) => keep.has(f.id));
write('coverage_us_states.geojson', states,
  `npm us-atlas ${require('us-atlas/package.json').version} states-10m.json, topojson-client ${require('topojson-client/package.json').version}`);

const world = require('world-atlas/countries-110m.json');
write('coverage_world_110m.geojson', topojson.feature(world, world.objects.countries),
  `npm world-atlas ${require('world-atlas/package.json').version} countries-110m.json, topojson-client ${require('topojson-client/package.json').version}`);
