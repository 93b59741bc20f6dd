// The map page: load GeoJSON, fit it with POST /v1/fit (the public API, nothing private), draw
// the input and the fit on the globe, list the numbers, download the results. A file of curves
// without geometry (a fit with carry=spline: compact curves, or JSON splines) is drawn through
// POST /v1/evaluate instead of fitted.
import * as G from './globe.js';

const $ = (id) => document.getElementById(id);
const el = {
  canvas: $('map'), file: $('file'), sample: $('sample'), loadSample: $('load-sample'),
  info: $('input-info'), form: $('options'), tolerance: $('tolerance'), cp: $('control-points'),
  degree: $('degree'), knots: $('knots'), solver: $('solver'), modeNote: $('mode-note'),
  showControl: $('show-control'), showPoints: $('show-points'), status: $('status'),
  request: $('request'), problem: $('problem'), dlFitted: $('download-fitted'),
  dlCurves: $('download-curves'), thead: document.querySelector('#features thead'),
  tbody: document.querySelector('#features tbody'), tableNote: $('table-note'),
  cancel: $('cancel'), legend: $('legend'), legendRamp: $('legend-ramp'), legendText: $('legend-text'),
};

/** Steps longer than this are drawn as several, so great-circle arcs look like arcs. */
const MAX_STEP_RAD = 1 * (Math.PI / 180);
/** Above this many input positions, points are drawn as small squares without outlines. */
const MANY_POINTS = 20000;
/** Colour ramp for the point distances, low to high (ColorBrewer YlOrRd). */
const RAMP = ['#ffffb2', '#fed976', '#feb24c', '#fd8d3c', '#f03b20', '#bd0026'];
const BUCKETS = 16;
const MAX_ZOOM = 20000;
const QUERY_FOR_CONTROL = {
  tolerance_m: 'tolerance', control_points: 'control-points', degree: 'degree', knots: 'knots', solver: 'solver',
};

const state = {
  limits: null,
  land: [], // {vecs, hole}
  graticule: [],
  input: null, // {name, text, json, features: [{index, name, lines, points}], positions}
  result: null, // {text, json, url, features: [{fit, lines, controls, distances}]}
  problem: null, // {feature, vec}
  view: { lon0: 0, lat0: 20, zoom: 1 },
  fitGen: 0,
  abort: null,
};

// ---------- numbers and text ----------

const fmtInt = (n) => n.toLocaleString('en-US');
const fmtBytes = (b) => (b >= 1048576 ? `${(b / 1048576).toFixed(1)} MiB` : b >= 1024 ? `${(b / 1024).toFixed(1)} KiB` : `${b} bytes`);
/** A metre value as the API gave it (up to 3 decimals), so what is shown is what was sent. */
const fmtM = (x) => (x == null || Number.isNaN(x) ? '–' : String(x));

function setStatus(stateName, text) {
  el.status.dataset.state = stateName;
  el.status.textContent = text;
}

// ---------- GeoJSON input ----------

const validPos = (p) => Array.isArray(p) && p.length >= 2 && Number.isFinite(p[0]) && Number.isFinite(p[1]) && Math.abs(p[0]) <= 180 && Math.abs(p[1]) <= 90;

/** Lines of a geometry as lists of [lon, lat] (rings closed as given), with their pointer. */
function geometryLines(g, base) {
  if (!g || typeof g !== 'object') return [];
  const c = g.coordinates;
  switch (g.type) {
    case 'LineString':
      return Array.isArray(c) ? [{ coords: c, pointer: `${base}/coordinates` }] : [];
    case 'MultiLineString':
    case 'Polygon':
      return Array.isArray(c) ? c.map((l, i) => ({ coords: l, pointer: `${base}/coordinates/${i}` })) : [];
    case 'MultiPolygon':
      return Array.isArray(c) ? c.flatMap((p, i) => (Array.isArray(p) ? p.map((l, j) => ({ coords: l, pointer: `${base}/coordinates/${i}/${j}` })) : [])) : [];
    case 'GeometryCollection':
      return Array.isArray(g.geometries) ? g.geometries.flatMap((x, i) => geometryLines(x, `${base}/geometries/${i}`)) : [];
    default:
      return [];
  }
}

function featureName(f) {
  const p = (f && f.properties) || {};
  const name = f && f.id != null ? f.id : p.name ?? p.NAME ?? p.title;
  return name == null ? null : String(name);
}

/** The features of a GeoJSON document as the service sees them: a FeatureCollection's
 * features, or one Feature, or one bare geometry. */
function documentFeatures(json) {
  if (!json || typeof json !== 'object') return [];
  if (json.type === 'FeatureCollection' && Array.isArray(json.features)) {
    return json.features.map((f, i) => ({ f, base: `/features/${i}/geometry` }));
  }
  if (json.type === 'Feature') return [{ f: json, base: '/geometry' }];
  return [{ f: { type: 'Feature', geometry: json }, base: '' }];
}

function linesToVecs(coordsList) {
  return coordsList.map((coords) => {
    const v = (Array.isArray(coords) ? coords : []).filter(validPos).map((p) => G.toVec(p[0], p[1]));
    return G.densify(v, MAX_STEP_RAD);
  });
}

function readInput(name, text, json) {
  const features = [];
  let positions = 0;
  if (json) {
    documentFeatures(json).forEach(({ f, base }, index) => {
      const lines = geometryLines(f && f.geometry, base);
      const pts = [];
      for (const l of lines) {
        if (!Array.isArray(l.coords)) continue;
        positions += l.coords.length;
        l.coords.forEach((p, j) => {
          if (validPos(p)) pts.push({ vec: G.toVec(p[0], p[1]), pointer: `${l.pointer}/${j}` });
        });
      }
      features.push({ index, name: featureName(f), lines: linesToVecs(lines.map((l) => l.coords)), points: pts, pointers: lines.map((l) => l.pointer) });
    });
  }
  return { name, text, json, features, positions };
}

// ---------- loading ----------

async function loadBlob(name, blob) {
  // A fit still under way is for the previous file: stop it, so its answer cannot land on this one.
  state.fitGen++;
  if (state.abort) state.abort.abort();
  state.abort = null;
  state.lastFit = null;
  el.cancel.hidden = true;
  clearProblem();
  state.result = null;
  state.problem = null;
  renderTable();
  updateDownloads();
  const lim = state.limits;
  if (lim && blob.size > lim.max_body_bytes) {
    state.input = null;
    el.info.textContent = `${name}: ${fmtBytes(blob.size)}`;
    setStatus('refused', `“${name}” is ${fmtBytes(blob.size)}; this server accepts at most ${fmtBytes(lim.max_body_bytes)} per request (max_body_bytes; spherefit serve --max-body-bytes). Split the file or simplify it first. Nothing was sent.`);
    draw();
    return;
  }
  setStatus('loading', `Reading ${name}…`);
  const text = await blob.text();
  let json = null;
  try {
    json = JSON.parse(text);
  } catch {
    // The service says what is wrong with it, with the line and column.
  }
  if (isCurvesFile(json)) {
    await drawCurves(name, text, json);
    return;
  }
  state.input = readInput(name, text, json);
  const n = state.input.positions;
  el.info.textContent = `${name}: ${fmtBytes(blob.size)}, ${state.input.features.length} feature${state.input.features.length === 1 ? '' : 's'}, ${fmtInt(n)} line and ring positions`;
  if (lim && n > lim.max_points) {
    // Kept so the map shows it, but never sent: an option changed later must not send it either.
    state.input.refused = true;
    setStatus('refused', `“${name}” has ${fmtInt(n)} line and ring positions; this server fits at most ${fmtInt(lim.max_points)} per request (max_points; spherefit serve --max-points). Split the file first, or use the batch CLI (spherefit fit), which streams any size. Nothing was sent.`);
    fitView();
    return;
  }
  fitView();
  fit(true);
}

/** Whether a document is curves to draw rather than lines to fit: every feature has no
 * geometry and carries a fit's or an interpolation's spline (a compact curve, base64 text, or a
 * JSON spline), as `carry=spline` writes them. */
function isCurvesFile(json) {
  const fs = documentFeatures(json).map(({ f }) => f);
  const carries = (f) => {
    const c = f && f.properties && (f.properties.fit || f.properties.interpolation);
    return !!c && (c.spline != null || (Array.isArray(c.parts) && c.parts.some((p) => p && p.spline != null)));
  };
  return !!json && json.type !== undefined && fs.length > 0 && fs.every((f) => f && f.type === 'Feature' && f.geometry == null && carries(f));
}

/** The features of a /v1/fit or /v1/evaluate answer as the page draws and lists them. */
function resultFeatures(json) {
  const out = Array.isArray(json.features) ? json.features : [json];
  return out.map((f, i) => {
    const fit = f && f.properties && (f.properties.fit || f.properties.interpolation);
    if (!fit) return { index: i, fit: null };
    const lines = linesToVecs(geometryLines(f.geometry, '').map((l) => l.coords));
    // Compact curves are text: only JSON splines have control points to draw. A degree-1
    // spline written once ("control_points": "geometry") has its line's positions.
    const coords = geometryLines(f.geometry, '').map((l) => l.coords);
    const splines = (Array.isArray(fit.parts) ? fit.parts.map((p) => p.spline) : [fit.spline])
      .map((s, k) => (s && typeof s === 'object' && s.control_points === 'geometry' ? { ...s, control_points: coords[k] || [] } : s))
      .filter((s) => s && typeof s === 'object');
    const controls = linesToVecs(splines.map((s) => s.control_points || []));
    return { index: i, fit, feature: f, lines, controls, splines, distances: null };
  });
}

/** Draws a file of curves: POST /v1/evaluate turns each stored curve back into a line. */
async function drawCurves(name, text, json) {
  const gen = state.fitGen;
  state.input = { name, text, json, features: [], positions: 0, curves: true };
  const n = documentFeatures(json).length;
  el.info.textContent = `${name}: ${fmtBytes(text.length)}, ${n} stored curve${n === 1 ? '' : 's'} (no geometry)`;
  const url = '/v1/evaluate';
  el.request.textContent = `POST ${url}`;
  el.request.dataset.url = url;
  setStatus('fitting', `Drawing ${n} stored curve${n === 1 ? '' : 's'} (POST ${url})…`);
  let res;
  let body;
  try {
    res = await fetch(url, { method: 'POST', headers: { 'Content-Type': 'application/geo+json' }, body: text });
    body = await res.text();
  } catch (e) {
    if (gen !== state.fitGen) return;
    setStatus('error', `The request failed: ${e.message}. Is the server still running?`);
    draw();
    return;
  }
  if (gen !== state.fitGen) return;
  if (!res.ok) {
    let problem = null;
    try {
      problem = JSON.parse(body);
    } catch {
      problem = { title: `HTTP ${res.status}`, status: res.status, detail: body.slice(0, 500) };
    }
    showProblem(problem, res.headers.get('Retry-After'));
    setStatus('error', `The service could not draw these curves (${res.status} ${problem.title || ''}).`);
    draw();
    return;
  }
  const out = JSON.parse(body);
  const features = resultFeatures(out);
  state.result = { text: body, json: out, url, features, ms: 0, scaleMax: 0, curves: true };
  renderTable();
  updateDownloads();
  const drawn = features.filter((f) => f.fit && f.lines.length).length;
  setStatus('done', `Drew ${drawn} of ${features.length} stored curve${features.length === 1 ? '' : 's'} from ${name} (POST /v1/evaluate); nothing was fitted.`);
  fitView();
}

async function loadSample() {
  const which = el.sample.value;
  const res = await fetch(`/page/sample-${which}.geojson`);
  const blob = await res.blob();
  await loadBlob(`sample-${which}.geojson`, blob);
}

// ---------- fitting ----------

function mode() {
  return el.form.querySelector('input[name="mode"]:checked').value;
}

function query() {
  const q = new URLSearchParams();
  const m = mode();
  if (m === 'tolerance') q.set('tolerance_m', el.tolerance.value.trim());
  if (m === 'control_points') q.set('control_points', el.cp.value.trim());
  q.set('degree', el.degree.value);
  if (m !== 'tolerance') {
    q.set('knots', el.knots.value);
    q.set('solver', el.solver.value);
  }
  return q;
}

function updateModeControls() {
  const m = mode();
  el.tolerance.disabled = m !== 'tolerance';
  el.cp.disabled = m !== 'control_points';
  el.knots.disabled = m === 'tolerance';
  el.solver.disabled = m === 'tolerance';
  el.modeNote.textContent =
    m === 'tolerance'
      ? 'A tolerance fit picks its own control points, knots and degree (at most Degree, and at most 3): every input point within the tolerance of the curve, with as few stored numbers as it finds.'
      : m === 'default'
        ? 'The default count: a quarter of the points as control points (at least degree + 1).'
        : 'Control points per curve: at least degree + 1, at most the curve’s distinct points.';
}

/** Fits the input with the options shown, unless that exact fit is already shown or under way
 * (`force`: the form was submitted). */
async function fit(force = false) {
  if (!state.input || state.input.refused || state.input.curves) return;
  const url = `/v1/fit?${query()}`;
  if (!force && state.lastFit && state.lastFit.url === url && state.lastFit.input === state.input) return;
  state.lastFit = { url, input: state.input };
  const gen = ++state.fitGen;
  if (state.abort) state.abort.abort();
  const abort = new AbortController();
  state.abort = abort;
  clearProblem();
  el.request.textContent = `POST ${url}`;
  el.request.dataset.url = url;
  el.cancel.hidden = false;
  setStatus('fitting', `Fitting ${state.input.features.length} feature${state.input.features.length === 1 ? '' : 's'} (${fmtInt(state.input.positions)} positions)…`);
  const t0 = performance.now();
  let res;
  let text;
  try {
    res = await fetch(url, { method: 'POST', headers: { 'Content-Type': 'application/geo+json' }, body: state.input.text, signal: abort.signal });
    text = await res.text();
  } catch (e) {
    if (gen !== state.fitGen) return;
    el.cancel.hidden = true;
    state.result = null;
    renderTable();
    updateDownloads();
    if (e.name !== 'AbortError') state.lastFit = null;
    if (e.name === 'AbortError') setStatus('idle', 'Fit cancelled; change an option or press Enter in a field to fit again.');
    else setStatus('error', `The request failed: ${e.message}. Is the server still running?`);
    draw();
    return;
  }
  if (gen !== state.fitGen) return;
  el.cancel.hidden = true;
  const ms = Math.round(performance.now() - t0);
  if (!res.ok) {
    state.result = null;
    renderTable();
    updateDownloads();
    let problem = null;
    try {
      problem = JSON.parse(text);
    } catch {
      problem = { title: `HTTP ${res.status}`, status: res.status, detail: text.slice(0, 500) };
    }
    showProblem(problem, res.headers.get('Retry-After'));
    setStatus('error', `The service refused the request (${res.status} ${problem.title || ''}).`);
    draw();
    return;
  }
  const json = JSON.parse(text);
  const features = resultFeatures(json);
  state.result = { text, json, url, features, ms, scaleMax: 0 };
  renderTable();
  updateDownloads();
  const fitted = features.filter((f) => f.fit).length;
  setStatus('done', `Fitted ${fitted} of ${features.length} feature${features.length === 1 ? '' : 's'} in ${fmtInt(ms)} ms.`);
  draw();
  await computeDistances(gen);
}

/** Distance from every input point to its feature's fitted line (great-circle steps of the
 * returned geometry), in chunks so a large file does not freeze the page. */
async function computeDistances(gen) {
  const r = state.result;
  let max = 0;
  for (const f of r.features) {
    if (!f.fit) continue;
    const inp = state.input.features[f.index];
    if (!inp) continue;
    const pts = inp.points.map((p) => p.vec);
    const d = [];
    for (let i = 0; i < pts.length; i += 5000) {
      d.push(...G.nearestDistances(pts.slice(i, i + 5000), f.lines).map((x) => x * G.EARTH_RADIUS_M));
      await new Promise((ok) => setTimeout(ok, 0));
      if (gen !== state.fitGen) return;
    }
    f.distances = d;
    for (const x of d) if (x > max) max = x;
  }
  r.maxDistance = max;
  r.scaleMax = mode() === 'tolerance' ? Number(el.tolerance.value) : max;
  el.canvas.dataset.maxDistanceM = max.toFixed(3);
  updateLegend();
  draw();
}

let refitTimer = null;
function refitSoon(delay = 350) {
  clearTimeout(refitTimer);
  refitTimer = setTimeout(fit, delay);
}

// ---------- problems ----------

function clearProblem() {
  el.problem.hidden = true;
  el.problem.textContent = '';
  for (const id of Object.values(QUERY_FOR_CONTROL)) $(id).removeAttribute('aria-invalid');
  state.problem = null;
}

const COMPONENT = ['longitude', 'latitude', 'altitude'];

/** "feature 1 (id …), line 0, position 17, latitude" from a JSON pointer into the body. */
function describePointer(ptr) {
  if (ptr == null) return null;
  if (ptr === '') return { text: 'the whole document' };
  const t = ptr.split('/').slice(1).map((s) => s.replace(/~1/g, '/').replace(/~0/g, '~'));
  const parts = [];
  let feature = null;
  let k = 0;
  if (t[0] === 'features' && /^\d+$/.test(t[1] || '')) {
    feature = Number(t[1]);
    const f = state.input && state.input.features[feature];
    parts.push(f && f.name != null ? `feature ${feature} (“${f.name}”)` : `feature ${feature}`);
    k = 2;
  }
  let coords = null;
  if (t[k] === 'geometry') k++;
  if (t[k] === 'coordinates') {
    coords = t.slice(k + 1).map(Number);
    const type = feature != null ? state.input?.json?.features?.[feature]?.geometry?.type : state.input?.json?.geometry?.type ?? state.input?.json?.type;
    const depth = { LineString: 1, MultiLineString: 2, Polygon: 2, MultiPolygon: 3 }[type] || 1;
    const names = depth === 3 ? ['polygon', 'ring'] : depth === 2 ? [type === 'Polygon' ? 'ring' : 'line'] : [];
    names.forEach((n, i) => {
      if (coords[i] != null) parts.push(`${n} ${coords[i]}`);
    });
    if (coords[depth - 1] != null) parts.push(`position ${coords[depth - 1]}`);
    if (coords[depth] != null) parts.push(COMPONENT[coords[depth]] || `component ${coords[depth]}`);
  } else if (k < t.length) {
    parts.push(t.slice(k).join('.'));
  }
  // The position on the map, if the pointer names one.
  let vec = null;
  let note = '';
  if (coords && state.input?.json) {
    const g = feature != null ? state.input.json.features?.[feature]?.geometry : state.input.json.geometry ?? state.input.json;
    let p = g && g.coordinates;
    const depth = { LineString: 1, MultiLineString: 2, Polygon: 2, MultiPolygon: 3 }[g?.type] || 1;
    for (let i = 0; i < depth - 1 && Array.isArray(p); i++) p = p[coords[i]];
    // The position itself, or (when it is not a valid position) the nearest valid one before it.
    const line = Array.isArray(p) ? p : [];
    for (let j = Math.min(coords[depth - 1] ?? 0, line.length - 1); j >= 0; j--) {
      if (validPos(line[j])) {
        vec = G.toVec(line[j][0], line[j][1]);
        if (j !== coords[depth - 1]) note = ` (marked on the map: position ${j}, the last valid one before it)`;
        break;
      }
    }
  }
  return { text: (parts.join(', ') || ptr) + note, feature, vec };
}

function showProblem(p, retryAfter) {
  el.problem.textContent = '';
  const h = document.createElement('h2');
  h.textContent = `${p.title || 'Error'}${p.status ? ` (${p.status})` : ''}`;
  el.problem.append(h);
  const d = document.createElement('p');
  d.className = 'detail';
  d.textContent = p.detail || '';
  el.problem.append(d);
  const where = describePointer(p.pointer);
  if (where) {
    const w = document.createElement('p');
    w.className = 'where';
    w.append(`Where: ${where.text} `);
    const code = document.createElement('code');
    code.textContent = p.pointer === '' ? '(pointer "")' : p.pointer;
    w.append(code);
    el.problem.append(w);
    state.problem = { feature: where.feature, vec: where.vec };
    if (where.vec) {
      const ll = G.toLonLat(where.vec);
      state.view.lon0 = ll[0];
      state.view.lat0 = ll[1];
      state.view.zoom = Math.max(state.view.zoom, 4);
    }
  }
  if (p.parameter) {
    const w = document.createElement('p');
    w.className = 'where';
    const control = QUERY_FOR_CONTROL[p.parameter];
    const label = control ? document.querySelector(`label[for="${control}"]`)?.textContent : null;
    w.textContent = `Where: query parameter ${p.parameter}${label ? ` (the “${label}” control)` : ''}`;
    el.problem.append(w);
    if (control) {
      $(control).setAttribute('aria-invalid', 'true');
      $(control).setAttribute('aria-describedby', 'problem');
    }
  }
  if (retryAfter) {
    const w = document.createElement('p');
    w.textContent = `The server asks to retry after ${retryAfter} s.`;
    el.problem.append(w);
  }
  if (p.type) {
    const w = document.createElement('p');
    w.className = 'muted';
    w.textContent = p.type;
    el.problem.append(w);
  }
  el.problem.hidden = false;
}

// ---------- table ----------

function twoWayKey(fits) {
  for (const fit of fits) {
    for (const k of Object.keys(fit)) {
      if (/(two[_-]?way|hausdorff)/i.test(k) && typeof fit[k] === 'number') return k;
    }
  }
  return null;
}

/** Numbers needed to rebuild the curves of one feature's fit: the API's `stored_numbers` for
 * tolerance fits; otherwise counted the same way from the splines (2 per control point, each
 * interior knot unless the knots are uniform, 1 for the degree). */
function storedNumbers(f) {
  if (typeof f.fit.stored_numbers === 'number') return { value: f.fit.stored_numbers, computed: false };
  let n = 0;
  for (const s of f.splines) {
    const interior = Math.max(0, (s.knots?.length || 0) - 2 * (s.degree + 1));
    n += 2 * (s.control_points?.length || 0) + (f.fit.knots === 'uniform' ? 0 : interior) + 1;
  }
  return { value: n, computed: true };
}

function ratio(f, stored) {
  if (typeof f.fit.compression_ratio === 'number') return { value: f.fit.compression_ratio, computed: false };
  return { value: Math.round((2 * f.fit.input_points * 1000) / stored) / 1000, computed: true };
}

function renderTable() {
  updateLegend();
  el.thead.textContent = '';
  el.tbody.textContent = '';
  el.tableNote.textContent = '';
  const r = state.result;
  if (!r) return;
  const fits = r.features.filter((f) => f.fit).map((f) => f.fit);
  const tw = twoWayKey(fits);
  const hasTol = fits.some((f) => typeof f.tolerance_met === 'boolean');
  const cols = [
    ['feature', 'Feature'],
    ['input_points', 'Points in'],
    ['stored_numbers', 'Numbers stored'],
    ['compression_ratio', 'Ratio'],
    ['max_error_m', 'Max error (m)'],
    ['mean_error_m', 'Mean error (m)'],
  ];
  if (tw) cols.push([tw, 'Two-way (m)']);
  if (hasTol) cols.push(['tolerance_met', 'Tolerance met']);
  const hr = document.createElement('tr');
  for (const [key, name] of cols) {
    const th = document.createElement('th');
    th.scope = 'col';
    th.textContent = name;
    th.dataset.field = key;
    hr.append(th);
  }
  el.thead.append(hr);
  let anyComputed = false;
  for (const f of r.features) {
    const tr = document.createElement('tr');
    tr.dataset.feature = f.index;
    // A file of curves has no input lines: the names are those of the drawn features.
    const name = state.input?.features[f.index]?.name ?? (f.feature ? featureName(f.feature) : null);
    const th = document.createElement('th');
    th.scope = 'row';
    th.textContent = name == null ? String(f.index) : `${f.index} · ${name}`;
    tr.append(th);
    if (!f.fit) {
      const td = document.createElement('td');
      td.colSpan = cols.length - 1;
      td.className = 'skipped';
      const g = state.result.json.features?.[f.index]?.geometry;
      td.textContent = `not fitted: ${g ? g.type : 'no geometry'}, passed through`;
      tr.append(td);
      el.tbody.append(tr);
      continue;
    }
    const stored = storedNumbers(f);
    const rat = ratio(f, stored.value);
    anyComputed ||= stored.computed;
    const cells = {
      input_points: { value: f.fit.input_points },
      stored_numbers: stored,
      compression_ratio: rat,
      max_error_m: { value: f.fit.max_error_m },
      mean_error_m: { value: f.fit.mean_error_m },
    };
    if (tw) cells[tw] = { value: f.fit[tw] };
    if (hasTol) cells.tolerance_met = { value: f.fit.tolerance_met, text: f.fit.tolerance_met ? 'yes' : 'no' };
    if (hasTol && f.fit.tolerance_met === false) tr.className = 'bad';
    for (const [key] of cols.slice(1)) {
      const c = cells[key] || { value: null };
      const td = document.createElement('td');
      td.dataset.field = key;
      td.textContent = c.text ?? (typeof c.value === 'number' ? (Number.isInteger(c.value) && key !== 'max_error_m' && key !== 'mean_error_m' ? fmtInt(c.value) : fmtM(c.value)) : '–');
      if (c.computed) {
        td.classList.add('computed');
        td.title = 'computed by the page from properties.fit.spline';
      }
      tr.append(td);
    }
    el.tbody.append(tr);
  }
  const notes = [
    'Errors are the API’s: parametric geodesic errors of the returned spline at each input point, in metres.',
    'The colours of the input points on the map are computed by this page, since the API reports errors per feature, not per point: each point’s distance to the nearest point of its feature’s fitted line as returned (great-circle steps between the output positions), so it also includes the sampling deviation of the output line.',
  ];
  if (anyComputed) notes.push('* computed by the page from properties.fit.spline: 2 numbers per control point, each interior knot (unless knots are uniform) and the degree; ratio = 2 × points in / numbers stored.');
  if (!tw) notes.push('This server reports no two-way (Hausdorff) distance; the column appears when properties.fit carries one.');
  el.tableNote.textContent = notes.join(' ');
}

// ---------- downloads ----------

function baseName() {
  const n = state.input?.name || 'spherefit';
  return n.replace(/\.(geo)?json$/i, '');
}

function download(name, text) {
  const url = URL.createObjectURL(new Blob([text], { type: 'application/geo+json' }));
  const a = document.createElement('a');
  a.href = url;
  a.download = name;
  document.body.append(a);
  a.click();
  a.remove();
  setTimeout(() => URL.revokeObjectURL(url), 10000);
}

/** The fit shown, asked again with `carry=spline`: each fitted feature without its dense
 * line, its curve a compact curve (base64 text in properties.fit.spline, or in each of
 * properties.fit.parts) at the precision its tolerance needs. The page draws such a file
 * (through POST /v1/evaluate), as `spherefit evaluate` and Python's `evaluate` do. */
async function downloadCompactCurves() {
  const r = state.result;
  const input = state.input;
  if (!r || !input) return;
  if (r.curves) {
    download(`${baseName()}.curves.geojson`, input.text);
    return;
  }
  const url = `${r.url}&carry=spline`;
  el.dlCurves.disabled = true;
  setStatus('fitting', `Asking for the compact curves (POST ${url})…`);
  try {
    const res = await fetch(url, { method: 'POST', headers: { 'Content-Type': 'application/geo+json' }, body: input.text });
    const text = await res.text();
    if (!res.ok) {
      setStatus('error', `The service refused the compact curves (${res.status}).`);
      return;
    }
    download(`${baseName()}.curves.geojson`, text);
    setStatus('done', `Downloaded the compact curves (${fmtBytes(text.length)}, the fitted GeoJSON is ${fmtBytes(r.text.length)}).`);
  } catch (e) {
    setStatus('error', `The request failed: ${e.message}. Is the server still running?`);
  } finally {
    updateDownloads();
  }
}

function updateDownloads() {
  const ok = !!state.result;
  el.dlFitted.disabled = !ok;
  el.dlCurves.disabled = !ok;
}

// ---------- drawing ----------

function precomputeLand(geojson) {
  const out = [];
  for (const f of geojson.features) {
    const polys = f.geometry.type === 'Polygon' ? [f.geometry.coordinates] : f.geometry.coordinates;
    for (const poly of polys) {
      poly.forEach((ring, i) => {
        const v = ring.slice(0, -1).map(([lon, lat]) => G.toVec(lon, lat));
        out.push({ vecs: G.densify(v, 2 * MAX_STEP_RAD, true), hole: i > 0 });
      });
    }
  }
  return out;
}

function precomputeGraticule() {
  const lines = [];
  for (let lon = -180; lon < 180; lon += 30) {
    const l = [];
    for (let lat = -90; lat <= 90; lat += 2) l.push(G.toVec(lon, lat));
    lines.push(l);
  }
  for (let lat = -60; lat <= 60; lat += 30) {
    const l = [];
    for (let lon = -180; lon <= 180; lon += 2) l.push(G.toVec(lon, lat));
    lines.push(l);
  }
  return lines;
}

function rampColour(t) {
  const x = Math.max(0, Math.min(1, t)) * (RAMP.length - 1);
  const i = Math.min(RAMP.length - 2, Math.floor(x));
  const f = x - i;
  const a = RAMP[i].match(/\w\w/g).map((h) => parseInt(h, 16));
  const b = RAMP[i + 1].match(/\w\w/g).map((h) => parseInt(h, 16));
  return `rgb(${a.map((v, k) => Math.round(v + f * (b[k] - v))).join(',')})`;
}

function updateLegend() {
  const r = state.result;
  if (!r || r.maxDistance == null) {
    el.legend.hidden = true;
    return;
  }
  el.legend.hidden = false;
  el.legendRamp.style.background = `linear-gradient(to right, ${RAMP.join(',')})`;
  const tol = mode() === 'tolerance';
  el.legendText.textContent = `Point colour: distance to the fitted line, 0 to ${r.scaleMax.toFixed(1)} m${tol ? ' (the tolerance)' : ''}; largest ${r.maxDistance.toFixed(1)} m. Computed by this page.`;
}

function viewGeometry() {
  const c = el.canvas;
  const w = c.clientWidth;
  const h = c.clientHeight;
  const R = 0.45 * Math.min(w, h) * state.view.zoom;
  return { w, h, R, cx: w / 2, cy: h / 2 };
}

function draw() {
  const c = el.canvas;
  const dpr = window.devicePixelRatio || 1;
  const { w, h, R, cx, cy } = viewGeometry();
  if (c.width !== Math.round(w * dpr) || c.height !== Math.round(h * dpr)) {
    c.width = Math.round(w * dpr);
    c.height = Math.round(h * dpr);
  }
  const ctx = c.getContext('2d');
  ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
  ctx.clearRect(0, 0, w, h);
  const view = new G.View(state.view.lon0, state.view.lat0);
  const X = (p) => cx + p[0] * R;
  const Y = (p) => cy - p[1] * R;
  const pathOf = (pts, close) => {
    ctx.moveTo(X(pts[0]), Y(pts[0]));
    for (let i = 1; i < pts.length; i++) ctx.lineTo(X(pts[i]), Y(pts[i]));
    if (close) ctx.closePath();
  };
  const strokeLines = (lines, style, width, dash = []) => {
    ctx.beginPath();
    let n = 0;
    for (const line of lines) {
      for (const run of G.clipLine(line.map((v) => view.apply(v)))) {
        if (run.length < 2) continue;
        pathOf(run, false);
        n++;
      }
    }
    ctx.setLineDash(dash);
    ctx.strokeStyle = style;
    ctx.lineWidth = width;
    ctx.stroke();
    ctx.setLineDash([]);
    return n;
  };
  // Ocean, graticule, land.
  ctx.beginPath();
  ctx.arc(cx, cy, R, 0, 2 * Math.PI);
  ctx.fillStyle = '#d4e6f4';
  ctx.fill();
  strokeLines(state.graticule, 'rgba(80,110,140,0.25)', 0.7);
  ctx.beginPath();
  for (const ring of state.land) {
    const pts = ring.vecs.map((v) => view.apply(v));
    const paths = ring.hole ? G.clipRing(pts.reverse()).map((p) => p.reverse()) : G.clipRing(pts);
    for (const p of paths) if (p.length >= 3) pathOf(p, true);
  }
  ctx.fillStyle = '#efe9d8';
  ctx.fill('nonzero');
  ctx.strokeStyle = '#efe9d8';
  ctx.lineWidth = 0.8;
  ctx.stroke();
  ctx.beginPath();
  ctx.arc(cx, cy, R, 0, 2 * Math.PI);
  ctx.strokeStyle = '#8aa2b8';
  ctx.lineWidth = 1;
  ctx.stroke();

  const stats = { inputRuns: 0, fittedRuns: 0, controlPoints: 0, points: 0 };
  const inp = state.input;
  const r = state.result;
  if (r) {
    stats.fittedRuns = strokeLines(r.features.filter((f) => f.fit).flatMap((f) => f.lines), 'rgba(31,95,191,0.8)', 3.2);
  }
  if (inp && el.showPoints.checked) {
    const many = inp.positions > MANY_POINTS;
    const buckets = Array.from({ length: BUCKETS + 1 }, () => []);
    for (const f of inp.features) {
      const rf = r && r.features[f.index];
      const d = rf && rf.distances;
      f.points.forEach((p, i) => {
        const q = view.apply(p.vec);
        if (q[2] <= 0) return;
        const x = X(q);
        const y = Y(q);
        if (x < -5 || y < -5 || x > w + 5 || y > h + 5) return;
        const b = d && r.scaleMax > 0 ? Math.min(BUCKETS - 1, Math.floor((d[i] / r.scaleMax) * BUCKETS)) : d ? 0 : BUCKETS;
        buckets[b].push(x, y);
        stats.points++;
      });
    }
    const radius = stats.points > 2000 ? 1.6 : stats.points > 300 ? 2.2 : 2.8;
    buckets.forEach((xy, b) => {
      if (!xy.length) return;
      ctx.beginPath();
      for (let i = 0; i < xy.length; i += 2) {
        if (many) ctx.rect(xy[i] - 1, xy[i + 1] - 1, 2, 2);
        else {
          ctx.moveTo(xy[i] + radius, xy[i + 1]);
          ctx.arc(xy[i], xy[i + 1], radius, 0, 2 * Math.PI);
        }
      }
      ctx.fillStyle = b === BUCKETS ? '#ffffff' : rampColour((b + 0.5) / BUCKETS);
      ctx.fill();
      if (!many) {
        ctx.strokeStyle = 'rgba(30,30,30,0.8)';
        ctx.lineWidth = radius > 2 ? 0.8 : 0.5;
        ctx.stroke();
      }
    });
  }
  if (inp) {
    stats.inputRuns = strokeLines(inp.features.flatMap((f) => f.lines), 'rgba(25,25,25,0.9)', 1);
    if (state.problem && state.problem.feature != null && inp.features[state.problem.feature]) {
      strokeLines(inp.features[state.problem.feature].lines, '#b3261e', 3);
    }
  }
  if (r) {
    if (el.showControl.checked) {
      const polys = r.features.filter((f) => f.fit).flatMap((f) => f.controls.map((cp, i) => ({ cp, raw: f.splines[i].control_points })));
      strokeLines(polys.map((p) => p.cp), '#7b2cbf', 1.2, [5, 4]);
      ctx.beginPath();
      for (const p of polys) {
        for (const [lon, lat] of p.raw) {
          const q = view.apply(G.toVec(lon, lat));
          if (q[2] <= 0) continue;
          ctx.rect(X(q) - 3, Y(q) - 3, 6, 6);
          stats.controlPoints++;
        }
      }
      ctx.fillStyle = '#7b2cbf';
      ctx.fill();
    }
  }
  if (state.problem && state.problem.vec) {
    const q = view.apply(state.problem.vec);
    if (q[2] > 0) {
      ctx.beginPath();
      ctx.arc(X(q), Y(q), 9, 0, 2 * Math.PI);
      ctx.strokeStyle = '#b3261e';
      ctx.lineWidth = 3;
      ctx.stroke();
    }
  }
  c.dataset.view = `${state.view.lon0.toFixed(4)},${state.view.lat0.toFixed(4)},${state.view.zoom.toFixed(4)}`;
  c.dataset.drawnInputRuns = stats.inputRuns;
  c.dataset.drawnFittedRuns = stats.fittedRuns;
  c.dataset.drawnControlPoints = stats.controlPoints;
  c.dataset.drawnPoints = stats.points;
}

let drawQueued = false;
function redraw() {
  if (drawQueued) return;
  drawQueued = true;
  requestAnimationFrame(() => {
    drawQueued = false;
    draw();
  });
}

/** Centres the view on the data and zooms so all of it shows. */
function fitView() {
  const vecs = [];
  for (const f of state.input?.features || []) for (const l of f.lines) for (const v of l) vecs.push(v);
  // A file of curves has no input lines: the drawn curves then.
  if (!vecs.length) for (const f of state.result?.features || []) for (const l of f.lines || []) for (const v of l) vecs.push(v);
  if (!vecs.length) {
    draw();
    return;
  }
  let s = [0, 0, 0];
  for (const v of vecs) s = [s[0] + v[0], s[1] + v[1], s[2] + v[2]];
  const c = Math.hypot(...s) > 1e-9 ? G.normalize(s) : vecs[0];
  let far = 0;
  for (const v of vecs) far = Math.max(far, G.angle(c, v));
  const [lon0, lat0] = G.toLonLat(c);
  const zoom = far >= Math.PI / 2 * 0.9 ? 1 : Math.min(MAX_ZOOM, Math.max(1, 1 / Math.sin(Math.max(far, 1e-7)) / 1.1));
  state.view = { lon0, lat0, zoom };
  draw();
}

function pan(dxPx, dyPx) {
  const { R } = viewGeometry();
  const k = 180 / Math.PI / R;
  state.view.lon0 = ((state.view.lon0 - dxPx * k / Math.max(0.2, Math.cos(state.view.lat0 * Math.PI / 180)) + 540) % 360) - 180;
  state.view.lat0 = Math.max(-90, Math.min(90, state.view.lat0 + dyPx * k));
  redraw();
}

function zoomBy(f) {
  state.view.zoom = Math.max(0.5, Math.min(MAX_ZOOM, state.view.zoom * f));
  redraw();
}

// ---------- wiring ----------

function wire() {
  el.file.addEventListener('change', () => {
    const f = el.file.files[0];
    if (f) loadBlob(f.name, f);
  });
  el.loadSample.addEventListener('click', loadSample);
  document.addEventListener('dragover', (e) => {
    e.preventDefault();
    document.body.classList.add('dragging');
  });
  document.addEventListener('dragleave', (e) => {
    if (e.target === document.documentElement || e.clientX <= 0 || e.clientY <= 0) document.body.classList.remove('dragging');
  });
  document.addEventListener('drop', (e) => {
    e.preventDefault();
    document.body.classList.remove('dragging');
    const f = e.dataTransfer && e.dataTransfer.files[0];
    if (f) {
      el.file.value = '';
      loadBlob(f.name, f);
    }
  });
  el.form.addEventListener('submit', (e) => {
    e.preventDefault();
    fit(true);
  });
  el.form.addEventListener('change', (e) => {
    if (e.target === el.showControl || e.target === el.showPoints) {
      draw();
      return;
    }
    updateModeControls();
    refitSoon(0);
  });
  for (const input of [el.tolerance, el.cp]) input.addEventListener('input', () => refitSoon());
  el.dlFitted.addEventListener('click', () => download(`${baseName()}.fitted.geojson`, state.result.text));
  el.dlCurves.addEventListener('click', downloadCompactCurves);
  el.cancel.addEventListener('click', () => {
    clearTimeout(refitTimer);
    if (state.abort) state.abort.abort();
  });
  $('zoom-in').addEventListener('click', () => zoomBy(1.6));
  $('zoom-out').addEventListener('click', () => zoomBy(1 / 1.6));
  $('zoom-fit').addEventListener('click', fitView);

  const c = el.canvas;
  let drag = null;
  c.addEventListener('pointerdown', (e) => {
    drag = { x: e.clientX, y: e.clientY };
    c.setPointerCapture(e.pointerId);
    c.style.cursor = 'grabbing';
  });
  c.addEventListener('pointermove', (e) => {
    if (!drag) return;
    pan(e.clientX - drag.x, e.clientY - drag.y);
    drag = { x: e.clientX, y: e.clientY };
  });
  const end = () => {
    drag = null;
    c.style.cursor = '';
  };
  c.addEventListener('pointerup', end);
  c.addEventListener('pointercancel', end);
  c.addEventListener('wheel', (e) => {
    e.preventDefault();
    zoomBy(Math.exp(-e.deltaY * 0.0015));
  }, { passive: false });
  c.addEventListener('keydown', (e) => {
    const step = 0.1 * Math.min(c.clientWidth, c.clientHeight);
    const keys = {
      ArrowLeft: () => pan(step, 0), ArrowRight: () => pan(-step, 0), ArrowUp: () => pan(0, step), ArrowDown: () => pan(0, -step),
      '+': () => zoomBy(1.6), '=': () => zoomBy(1.6), '-': () => zoomBy(1 / 1.6), '0': fitView,
    };
    if (keys[e.key]) {
      e.preventDefault();
      keys[e.key]();
    }
  });
  new ResizeObserver(redraw).observe(c);
}

/** `#view=lon,lat,zoom` in the address shows that view (a link to a place). */
function viewFromHash() {
  const m = /view=(-?[\d.]+),(-?[\d.]+)(?:,([\d.]+))?/.exec(location.hash);
  if (!m) return false;
  state.view = { lon0: Number(m[1]), lat0: Math.max(-90, Math.min(90, Number(m[2]))), zoom: Math.max(0.5, Math.min(MAX_ZOOM, Number(m[3] || 1))) };
  draw();
  return true;
}

async function main() {
  wire();
  window.addEventListener('hashchange', viewFromHash);
  updateModeControls();
  state.graticule = precomputeGraticule();
  const [limits, land] = await Promise.all([
    fetch('/v1/limits').then((r) => r.json()),
    fetch('/page/land-110m.geojson').then((r) => r.json()),
  ]);
  state.limits = limits;
  state.land = precomputeLand(land);
  if (!viewFromHash()) draw();
  document.body.dataset.ready = 'true';
}

main().catch((e) => setStatus('error', `The page could not start: ${e.message}`));
