// The globe of the map page: an orthographic view of the sphere, and clipping of lines and
// rings at its horizon.
//
// Everything is done on unit vectors, never in longitude/latitude, so the antimeridian and the
// poles are ordinary places: a line from 179.9° to -179.9° is a 0.2° step, a line over a pole is
// a short arc. The view looks at the sphere from outside above `centre`; view coordinates are
// x east, y north, z towards the viewer, so the visible hemisphere is z > 0 and the horizon is
// the unit circle in (x, y). Shapes come out in that unit disc; the page scales them to pixels.
//
// Ring convention: the region of a ring is the side on its left (counterclockwise seen from
// outside the sphere), as RFC 7946 wants for exterior rings. `orientSmallLeft` makes any ring
// follow it for the smaller of its two sides.

export const EARTH_RADIUS_M = 6371008.8;
const D2R = Math.PI / 180;
const TAU = 2 * Math.PI;

export function toVec(lon, lat) {
  const l = lon * D2R;
  const p = lat * D2R;
  const c = Math.cos(p);
  return [c * Math.cos(l), c * Math.sin(l), Math.sin(p)];
}

export function toLonLat(v) {
  return [Math.atan2(v[1], v[0]) / D2R, Math.asin(Math.max(-1, Math.min(1, v[2]))) / D2R];
}

export const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
export const cross = (a, b) => [
  a[1] * b[2] - a[2] * b[1],
  a[2] * b[0] - a[0] * b[2],
  a[0] * b[1] - a[1] * b[0],
];
const len = (a) => Math.hypot(a[0], a[1], a[2]);
export const normalize = (a) => {
  const n = len(a);
  return [a[0] / n, a[1] / n, a[2] / n];
};

/** Angle between unit vectors, radians (the atan2 form: accurate at every angle). */
export function angle(a, b) {
  return Math.atan2(len(cross(a, b)), dot(a, b));
}

/** Point at fraction t of the great-circle arc a -> b (SLERP). */
export function slerp(a, b, t) {
  const w = angle(a, b);
  if (w < 1e-9) return normalize([a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]), a[2] + t * (b[2] - a[2])]);
  const s = Math.sin(w);
  const ka = Math.sin((1 - t) * w) / s;
  const kb = Math.sin(t * w) / s;
  return [ka * a[0] + kb * b[0], ka * a[1] + kb * b[1], ka * a[2] + kb * b[2]];
}

/** Inserts points so that no step of the polyline is longer than `maxStepRad`: great-circle
 * arcs project to curves, so a long step drawn as a straight segment would be wrong. */
export function densify(vecs, maxStepRad, closed = false) {
  const out = [];
  const n = vecs.length;
  const last = closed ? n : n - 1;
  for (let i = 0; i < last; i++) {
    const a = vecs[i];
    const b = vecs[(i + 1) % n];
    out.push(a);
    const w = angle(a, b);
    const k = Math.ceil(w / maxStepRad);
    for (let j = 1; j < k; j++) out.push(slerp(a, b, j / k));
  }
  if (!closed && n > 0) out.push(vecs[n - 1]);
  return out;
}

/** Signed area (steradians) of the triangle a, b, c (Van Oosterom & Strackee 1983). */
function triangleArea(a, b, c) {
  return 2 * Math.atan2(dot(a, cross(b, c)), 1 + dot(a, b) + dot(b, c) + dot(c, a));
}

/** Area (steradians, in (0, 4π)) of the region on the left of a closed ring of unit vectors
 * (first point not repeated at the end). */
export function areaLeft(ring) {
  // A fan of triangles from a reference point off the ring; the sum is the area modulo 4π.
  const o = normalize([0.1234, -0.5678, 0.8136]);
  let s = 0;
  for (let i = 0; i < ring.length; i++) s += triangleArea(o, ring[i], ring[(i + 1) % ring.length]);
  const fourPi = 2 * TAU;
  return ((s % fourPi) + fourPi) % fourPi;
}

/** The ring, reversed if needed so that its smaller side is on its left. */
export function orientSmallLeft(ring) {
  return areaLeft(ring) > TAU ? ring.slice().reverse() : ring;
}

/** Drops repeated points and spikes (A, B, A): a ring that runs out along a line and back (as
 * Natural Earth rings do along the antimeridian) encloses nothing there. */
export function cleanRing(ring) {
  const same = (a, b) => angle(a, b) < 1e-10;
  const out = [];
  for (const p of ring) {
    if (out.length && same(out[out.length - 1], p)) continue;
    if (out.length >= 2 && same(out[out.length - 2], p)) {
      out.pop(); // the tip of A, B, A; p is the A already kept
      continue;
    }
    out.push(p);
  }
  // The same across the seam where the ring closes.
  for (let changed = true; changed && out.length >= 3; ) {
    changed = false;
    const n = out.length;
    if (same(out[n - 1], out[0])) {
      out.pop();
      changed = true;
    } else if (same(out[n - 2], out[0])) {
      out.pop();
      changed = true;
    } else if (same(out[n - 1], out[1])) {
      out.shift();
      changed = true;
    }
  }
  return out.length >= 3 ? out : [];
}

/** The view above (lon0, lat0), in degrees: maps unit vectors to view coordinates. */
export class View {
  constructor(lon0, lat0) {
    this.lon0 = lon0;
    this.lat0 = Math.max(-90, Math.min(90, lat0));
    const l = this.lon0 * D2R;
    this.c = toVec(this.lon0, this.lat0);
    this.e = [-Math.sin(l), Math.cos(l), 0];
    this.n = cross(this.c, this.e);
  }

  apply(v) {
    return [dot(v, this.e), dot(v, this.n), dot(v, this.c)];
  }

  /** The unit vector seen at unit-disc point (x, y), or null off the globe. */
  invert(x, y) {
    const r2 = x * x + y * y;
    if (r2 > 1) return null;
    const z = Math.sqrt(1 - r2);
    const { e, n, c } = this;
    return [x * e[0] + y * n[0] + z * c[0], x * e[1] + y * n[1] + z * c[1], x * e[2] + y * n[2] + z * c[2]];
  }
}

/** Where the arc from a (one side of the horizon) to b (the other) meets it: a point of the
 * unit circle. Steps are short (densified), so the chord's crossing is the arc's. */
function horizonCrossing(a, b) {
  const t = a[2] / (a[2] - b[2]);
  const x = a[0] + t * (b[0] - a[0]);
  const y = a[1] + t * (b[1] - a[1]);
  const r = Math.hypot(x, y) || 1;
  return [x / r, y / r];
}

/** The visible pieces of a polyline given in view coordinates: lists of unit-disc points, cut
 * at the horizon (the cut point included). */
export function clipLine(pts) {
  const runs = [];
  let cur = null;
  for (let i = 0; i < pts.length; i++) {
    const p = pts[i];
    const vis = p[2] > 0;
    if (i > 0) {
      const q = pts[i - 1];
      const qvis = q[2] > 0;
      if (vis !== qvis) {
        const h = horizonCrossing(q, p);
        if (vis) {
          cur = [h];
        } else {
          cur.push(h);
          runs.push(cur);
          cur = null;
        }
      }
    }
    if (vis) {
      if (!cur) cur = [];
      cur.push([p[0], p[1]]);
    }
  }
  if (cur && cur.length) runs.push(cur);
  return runs;
}

/** Points along the horizon from angle `from` counterclockwise by `sweep` radians (ends
 * excluded). */
function limbArc(from, sweep) {
  const out = [];
  const k = Math.ceil(sweep / (2 * D2R));
  for (let j = 1; j < k; j++) {
    const t = from + (sweep * j) / k;
    out.push([Math.cos(t), Math.sin(t)]);
  }
  return out;
}

export function circle(steps = 180) {
  const out = [];
  for (let j = 0; j < steps; j++) out.push([Math.cos((TAU * j) / steps), Math.sin((TAU * j) / steps)]);
  return out;
}

/** Winding number of a closed ring (view coordinates) around the view axis. */
function windingAroundAxis(pts) {
  let s = 0;
  for (let i = 0; i < pts.length; i++) {
    const a = pts[i];
    const b = pts[(i + 1) % pts.length];
    let d = Math.atan2(b[1], b[0]) - Math.atan2(a[1], a[0]);
    if (d > Math.PI) d -= TAU;
    if (d < -Math.PI) d += TAU;
    s += d;
  }
  return Math.round(s / TAU);
}

/** The visible part of the region on the left of a closed ring (view coordinates, densified,
 * first point not repeated): closed paths in the unit disc, counterclockwise, the horizon
 * closing them where the ring goes behind the globe. */
export function clipRing(pts) {
  const n = pts.length;
  if (n < 3) return [];
  const vis = pts.map((p) => p[2] > 0);
  const i0 = vis.indexOf(false);
  if (i0 < 0) return [pts.map((p) => [p[0], p[1]])];
  if (!vis.includes(true)) {
    // All behind: the region holds the whole visible hemisphere iff it holds the centre.
    return windingAroundAxis(pts) === 1 ? [circle()] : [];
  }
  const runs = [];
  let cur = null;
  for (let k = 0; k < n; k++) {
    const i = (i0 + k) % n;
    const j = (i + 1) % n;
    if (vis[i] && cur) cur.pts.push([pts[i][0], pts[i][1]]);
    if (vis[i] !== vis[j]) {
      const h = horizonCrossing(pts[i], pts[j]);
      const th = Math.atan2(h[1], h[0]);
      if (vis[j]) {
        cur = { pts: [h], thIn: th };
      } else {
        cur.pts.push(h);
        cur.thOut = th;
        runs.push(cur);
        cur = null;
      }
    }
  }
  // Leaving the view, the region is on the left, so its boundary goes on counterclockwise
  // along the horizon to where the ring comes back.
  const used = runs.map(() => false);
  const out = [];
  for (let r0 = 0; r0 < runs.length; r0++) {
    if (used[r0]) continue;
    const path = [];
    let r = r0;
    for (let guard = 0; guard <= runs.length; guard++) {
      used[r] = true;
      path.push(...runs[r].pts);
      let best = -1;
      let bestSweep = Infinity;
      for (let s = 0; s < runs.length; s++) {
        if (used[s] && s !== r0) continue;
        const sweep = (((runs[s].thIn - runs[r].thOut) % TAU) + TAU) % TAU;
        if (sweep < bestSweep) {
          bestSweep = sweep;
          best = s;
        }
      }
      path.push(...limbArc(runs[r].thOut, bestSweep));
      if (best === r0 || best < 0) break;
      r = best;
    }
    out.push(path);
  }
  return out;
}

/** Geodesic distance (radians) from unit vector p to the great-circle arc a -> b. */
export function distanceToArc(p, a, b) {
  const nrm = cross(a, b);
  const nl = len(nrm);
  if (nl > 1e-15) {
    const n = [nrm[0] / nl, nrm[1] / nl, nrm[2] / nl];
    // p's foot on the great circle lies within the arc iff it is on the inner side of both ends.
    if (dot(cross(a, p), n) >= 0 && dot(cross(p, b), n) >= 0) {
      return Math.asin(Math.min(1, Math.abs(dot(p, n))));
    }
  }
  return Math.min(angle(p, a), angle(p, b));
}

/** For every point, the geodesic distance (radians) to the nearest point of the polylines
 * `lines` (lists of unit vectors, great-circle steps). A grid over 3-D space keeps it near
 * linear: segments are filed by midpoint in cells as wide as the longest segment, and the
 * search widens ring by ring until nothing outside can be nearer. */
export function nearestDistances(points, lines) {
  const segs = [];
  let lmax = 0;
  for (const line of lines) {
    for (let i = 0; i + 1 < line.length; i++) {
      const a = line[i];
      const b = line[i + 1];
      const m = [(a[0] + b[0]) / 2, (a[1] + b[1]) / 2, (a[2] + b[2]) / 2];
      lmax = Math.max(lmax, Math.hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]));
      segs.push([a, b, m]);
    }
    if (line.length === 1) segs.push([line[0], line[0], line[0]]);
  }
  if (!segs.length) return points.map(() => NaN);
  const cell = Math.max(lmax, 1e-7);
  const key = (i, j, k) => `${i},${j},${k}`;
  const grid = new Map();
  for (const s of segs) {
    const kk = key(Math.floor(s[2][0] / cell), Math.floor(s[2][1] / cell), Math.floor(s[2][2] / cell));
    let list = grid.get(kk);
    if (!list) grid.set(kk, (list = []));
    list.push(s);
  }
  const maxRing = Math.ceil(2 / cell) + 1;
  return points.map((p) => {
    const ci = Math.floor(p[0] / cell);
    const cj = Math.floor(p[1] / cell);
    const ck = Math.floor(p[2] / cell);
    let best = Infinity;
    for (let ring = 0; ring <= maxRing; ring++) {
      if (ring > 6) {
        // Far from everything: one pass over all segments is cheaper than more rings.
        for (const s of segs) best = Math.min(best, distanceToArc(p, s[0], s[1]));
        return best;
      }
      for (let di = -ring; di <= ring; di++)
        for (let dj = -ring; dj <= ring; dj++)
          for (let dk = -ring; dk <= ring; dk++) {
            if (Math.max(Math.abs(di), Math.abs(dj), Math.abs(dk)) !== ring) continue;
            const list = grid.get(key(ci + di, cj + dj, ck + dk));
            if (list) for (const s of list) best = Math.min(best, distanceToArc(p, s[0], s[1]));
          }
      // Every midpoint within ring·cell of p has been seen, so any unseen segment is at least
      // ring·cell − lmax/2 away (chord); stop once the best is nearer than that.
      const chordBest = 2 * Math.sin(Math.min(best, Math.PI) / 2);
      if (chordBest <= ring * cell - lmax / 2) return best;
    }
    return best;
  });
}
