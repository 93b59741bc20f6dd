// Unit tests of the map page's globe module (web/globe.js): projection, horizon clipping of
// lines and rings, ring orientation, point-to-line distances.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { readFileSync } from 'node:fs';
import * as G from '../../web/globe.js';

const close = (a, b, eps, what) => assert.ok(Math.abs(a - b) <= eps, `${what}: ${a} vs ${b}`);
const ring = (lonlats) => lonlats.map(([lo, la]) => G.toVec(lo, la));
/** Shoelace area of closed unit-disc paths (counterclockwise positive). */
const planarArea = (paths) => paths.reduce((s, p) => s + p.reduce((t, q, i) => { const r = p[(i + 1) % p.length]; return t + (q[0] * r[1] - r[0] * q[1]) / 2; }, 0), 0);

test('the view puts its centre in the middle, east to the right and north up', () => {
  for (const [lon, lat] of [[0, 0], [179.5, -30], [-120, 89.9], [45, -90]]) {
    const v = new G.View(lon, lat);
    const c = v.apply(G.toVec(lon, lat));
    close(c[0], 0, 1e-12, 'x');
    close(c[1], 0, 1e-12, 'y');
    close(c[2], 1, 1e-12, 'z');
    if (Math.abs(lat) < 80) {
      assert.ok(v.apply(G.toVec(lon + 1, lat))[0] > 0, 'east is +x');
      assert.ok(v.apply(G.toVec(lon, lat + 1))[1] > 0, 'north is +y');
    }
    const back = v.invert(0.3, -0.4);
    const f = v.apply(back);
    close(f[0], 0.3, 1e-12, 'invert x');
    close(f[1], -0.4, 1e-12, 'invert y');
  }
});

test('a line across the antimeridian is one short piece, not a line around the world', () => {
  const v = new G.View(180, 0);
  const line = G.densify(ring([[179.5, 0], [-179.5, 0]]), Math.PI / 180);
  const runs = G.clipLine(line.map((p) => v.apply(p)));
  assert.equal(runs.length, 1);
  const xs = runs[0].map((p) => p[0]);
  assert.ok(Math.max(...xs.map(Math.abs)) < 0.01, `${xs}`);
  assert.ok(xs[0] < 0 && xs[xs.length - 1] > 0, 'west to east');
});

test('a line over the pole stays continuous and the far side is cut at the horizon', () => {
  const v = new G.View(0, 90);
  const line = G.densify(ring([[0, 80], [180, 80]]), Math.PI / 180);
  const runs = G.clipLine(line.map((p) => v.apply(p)));
  assert.equal(runs.length, 1);
  assert.ok(runs[0].length > 10);
  // Seen from the equator at lon 0, the part beyond the pole is behind: cut at the horizon.
  const side = new G.View(0, 0);
  const cut = G.clipLine(G.densify(ring([[0, 0], [0, 60], [180, 60]]), Math.PI / 180).map((p) => side.apply(p)));
  assert.equal(cut.length, 1);
  const last = cut[0][cut[0].length - 1];
  close(Math.hypot(last[0], last[1]), 1, 1e-9, 'ends on the horizon');
});

test('ring orientation and area: the small side goes on the left', () => {
  // A 10° x 10° cell at the equator, its top edge along the parallel in 0.01° steps:
  // Δλ (sin φ1 − sin φ0) steradians.
  const steps = Array.from({ length: 1000 }, (_, i) => i / 100);
  const sq = ring([...steps.map((x) => [x, 0]), ...steps.map((y) => [10, y]), ...steps.map((x) => [10 - x, 10]), ...steps.map((y) => [0, 10 - y])]);
  const a = G.areaLeft(sq);
  close(a, (10 * Math.PI / 180) * Math.sin(10 * Math.PI / 180), 1e-8, 'area');
  close(G.areaLeft(sq.slice().reverse()), 4 * Math.PI - a, 1e-9, 'complement');
  assert.equal(G.orientSmallLeft(sq.slice().reverse())[0], sq[0]);
  // A ring around the South Pole (as Antarctica's), either way round.
  const polar = ring(Array.from({ length: 36 }, (_, i) => [-180 + 10 * i, -70]));
  assert.ok(G.areaLeft(G.orientSmallLeft(polar)) < 2 * Math.PI);
  assert.ok(G.areaLeft(G.orientSmallLeft(polar.slice().reverse())) < 2 * Math.PI);
});

test('cleanRing drops out-and-back spikes along the antimeridian', () => {
  const r = ring([[170, -10], [180, -10], [180, -20], [-180, -30], [180, -20], [-180, -10], [170, -5]]);
  const c = G.cleanRing(r);
  assert.equal(c.length, 3, JSON.stringify(c.map(G.toLonLat)));
});

test('ring clipping: visible, behind, straddling the horizon, holding the whole view', () => {
  const v = new G.View(0, 0);
  const sq = (lon0, lat0, d) => G.densify(ring([[lon0 - d, lat0 - d], [lon0 + d, lat0 - d], [lon0 + d, lat0 + d], [lon0 - d, lat0 + d]]), Math.PI / 180, true).map((p) => v.apply(p));
  // Wholly visible: itself.
  assert.equal(G.clipRing(sq(0, 0, 10)).length, 1);
  // Wholly behind and small: nothing.
  assert.deepEqual(G.clipRing(sq(180, 0, 10)), []);
  // Straddling the horizon at lon 90: a piece bounded by the horizon, less than half the square.
  const half = G.clipRing(sq(90, 0, 10));
  assert.equal(half.length, 1);
  const a = planarArea(half);
  assert.ok(a > 0 && a < 0.05, `area ${a}`);
  for (const p of half[0]) assert.ok(Math.hypot(p[0], p[1]) <= 1 + 1e-9);
  // A region holding the whole visible hemisphere, bounded behind the globe: the whole disc.
  const fromPole = new G.View(0, 90);
  const south = G.orientSmallLeft(ring(Array.from({ length: 36 }, (_, i) => [-180 + 10 * i, -30])));
  // The small side of the 30°S circle holds the South Pole; the north view sees none of it.
  assert.deepEqual(G.clipRing(G.densify(south, Math.PI / 180, true).map((p) => fromPole.apply(p))), []);
  // Its complement (the ring reversed) holds the North Pole: the whole disc.
  const all = G.clipRing(G.densify(south.slice().reverse(), Math.PI / 180, true).map((p) => fromPole.apply(p)));
  assert.equal(all.length, 1);
  close(planarArea(all), Math.PI, 0.01, 'disc area');
});

test('the basemap: every ring oriented with land on its left, none larger than a hemisphere', () => {
  const land = JSON.parse(readFileSync(new URL('../../web/land-110m.geojson', import.meta.url)));
  let rings = 0;
  let total = 0;
  for (const poly of land.features[0].geometry.coordinates) {
    poly.forEach((r, i) => {
      const v = r.slice(0, -1).map(([lo, la]) => G.toVec(lo, la));
      const a = G.areaLeft(v);
      if (i === 0) {
        assert.ok(a < 2 * Math.PI, `exterior ${rings} has ${a} sr on its left`);
        total += a;
      } else {
        assert.ok(a > 2 * Math.PI, `hole ${rings} is not clockwise`);
        total -= 4 * Math.PI - a;
      }
      rings++;
    });
  }
  // Land is 29 % of the Earth (148.9 of 510.1 million km²); 110m outlines are coarse.
  const share = total / (4 * Math.PI);
  assert.ok(share > 0.27 && share < 0.31, `land share ${share}`);
  assert.ok(rings > 100);
});

test('distances to a polyline: foot inside a segment, beyond its ends, and the grid agrees with brute force', () => {
  const line = ring([[0, 0], [1, 0], [2, 0]]);
  const R = G.EARTH_RADIUS_M;
  const [d1, d2] = G.nearestDistances(ring([[0.5, 0.1], [3, 0]]), [line]);
  close(d1 * R, 0.1 * Math.PI / 180 * R, 0.01, 'cross-track');
  close(d2 * R, 1 * Math.PI / 180 * R, 0.01, 'beyond the end');
  // Random points near a wiggly dense line: grid search equals brute force.
  let seed = 7;
  const rnd = () => ((seed = (seed * 16807) % 2147483647) / 2147483647);
  const wig = ring(Array.from({ length: 400 }, (_, i) => [170 + i * 0.05, 3 * Math.sin(i / 20)]).map(([lo, la]) => [lo > 180 ? lo - 360 : lo, la]));
  const pts = ring(Array.from({ length: 300 }, () => [170 + rnd() * 20, -4 + rnd() * 8]).map(([lo, la]) => [lo > 180 ? lo - 360 : lo, la]));
  const fast = G.nearestDistances(pts, [wig]);
  pts.forEach((p, i) => {
    let best = Infinity;
    for (let j = 0; j + 1 < wig.length; j++) best = Math.min(best, G.distanceToArc(p, wig[j], wig[j + 1]));
    close(fast[i], best, 1e-12, `point ${i}`);
  });
});
