// End-to-end test of the map page at GET /: Debian's Chromium, headless, driven by
// playwright-core against a running release server (started by .ci/browser.sh, which sets
// SPHEREFIT_URL and starts it with --max-body-bytes 1048576 --max-points 20000 so the limit
// paths can be tried with small files). Screenshots go to SPHEREFIT_SHOTS (target/browser).
import { test, before, after } from 'node:test';
import assert from 'node:assert/strict';
import { mkdtempSync, mkdirSync, readFileSync, rmSync, writeFileSync } from 'node:fs';
import { tmpdir } from 'node:os';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { chromium } from 'playwright-core';

const ROOT = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '../..');
const BASE = process.env.SPHEREFIT_URL;
const SHOTS = process.env.SPHEREFIT_SHOTS || path.join(ROOT, 'target/browser');
const BORDER = path.join(ROOT, 'fixtures/us_mexico_border_natural_earth.geojson');
const TRACKS_SEQ = path.join(ROOT, 'fixtures/batch_tracks.geojsons');
if (!BASE) throw new Error('SPHEREFIT_URL is not set: run .ci/browser.sh');

let browser;
let userDir;
let page;
const pageErrors = [];

before(async () => {
  mkdirSync(SHOTS, { recursive: true });
  userDir = mkdtempSync(path.join(tmpdir(), 'spherefit-chromium-'));
  browser = await chromium.launchPersistentContext(userDir, {
    executablePath: '/usr/bin/chromium',
    headless: true,
    args: [
      '--headless', '--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run',
      '--disable-background-networking', '--disable-component-update', '--disable-sync',
    ],
    viewport: { width: 1280, height: 800 },
    acceptDownloads: true,
  });
  page = browser.pages()[0] || (await browser.newPage());
  page.setDefaultTimeout(20000);
  page.on('pageerror', (e) => pageErrors.push(e.message));
  // Nothing but this server may be asked for anything.
  await page.route('**/*', (route) => {
    const u = route.request().url();
    if (u.startsWith(BASE) || u.startsWith('blob:') || u.startsWith('data:')) return route.continue();
    pageErrors.push(`request to another host: ${u}`);
    return route.abort();
  });
});

after(async () => {
  await browser?.close();
  if (userDir) rmSync(userDir, { recursive: true, force: true });
});

const shot = (name) => page.screenshot({ path: path.join(SHOTS, name) });

async function api(url, body) {
  const res = await fetch(BASE + url, { method: 'POST', headers: { 'Content-Type': 'application/geo+json' }, body });
  return { status: res.status, text: await res.text() };
}

/** Waits until the page has finished the fit it shows for `url` (query string included). */
async function waitForFit(fragment) {
  await page.waitForFunction(
    (f) => {
      const s = document.getElementById('status').dataset.state;
      const u = document.getElementById('request').dataset.url || '';
      return u.includes(f) && (s === 'done' || s === 'error') && document.getElementById('map').dataset.maxDistanceM !== undefined;
    },
    fragment,
  );
}

test('the page loads from this server alone and draws the basemap', async () => {
  const res = await page.goto(`${BASE}/`);
  assert.equal(res.status(), 200);
  assert.match(res.headers()['content-type'], /^text\/html/);
  assert.match(res.headers()['content-security-policy'], /default-src 'self'/);
  await page.waitForSelector('body[data-ready="true"]');
  await shot('01-empty.png');
  assert.deepEqual(pageErrors, []);
});

test('every control has an accessible name (Chromium accessibility tree)', async () => {
  const cdp = await browser.newCDPSession(page);
  const { nodes } = await cdp.send('Accessibility.getFullAXTree');
  const controls = nodes.filter((n) => ['textbox', 'spinbutton', 'combobox', 'checkbox', 'radio', 'button', 'slider'].includes(n.role?.value) && !n.ignored);
  const domCount = await page.evaluate(() => [...document.querySelectorAll('input, select, button')].filter((e) => !e.closest('[hidden]')).length);
  assert.ok(controls.length >= domCount, `${controls.length} controls in the tree, ${domCount} in the DOM`);
  for (const n of controls) assert.ok((n.name?.value || '').trim().length > 0, `a ${n.role.value} without a name`);
  const names = controls.map((n) => n.name.value);
  for (const want of ['GeoJSON file', 'Tolerance (m)', 'Control points', 'Degree', 'Knots', 'Solver', 'Show control polygon', 'Download fitted GeoJSON', 'Download compact curves', 'Zoom in']) {
    assert.ok(names.some((n) => n.includes(want)), `no control named ${want}: ${names.join(' | ')}`);
  }
  const map = nodes.find((n) => (n.name?.value || '').startsWith('Map of the input'));
  assert.ok(map, 'the map canvas has an accessible name');
  await cdp.detach();
});

test('Tab reaches every enabled control and the map, and keys move the map', async () => {
  // Radio buttons are one stop (the checked one); arrow keys move within the group.
  const want = await page.evaluate(() => [...document.querySelectorAll('input:not([disabled]):not([type="radio"]), input[type="radio"]:checked, select:not([disabled]), button:not([disabled]), #map')].filter((e) => !e.closest('[hidden]')).map((e) => e.id || e.name + ':' + e.value));
  await page.evaluate(() => document.activeElement?.blur());
  const seen = new Set();
  for (let i = 0; i < 60 && seen.size < want.length; i++) {
    await page.keyboard.press('Tab');
    seen.add(await page.evaluate(() => { const e = document.activeElement; return e.id || e.name + ':' + e.value; }));
  }
  for (const w of want) assert.ok(seen.has(w), `Tab never reached ${w}`);
  await page.focus('#mode-tolerance');
  await page.keyboard.press('ArrowDown');
  assert.ok(await page.isChecked('#mode-cp'), 'arrow keys move within the radio group');
  assert.ok(await page.isEnabled('#control-points'));
  await page.keyboard.press('ArrowUp');
  assert.ok(await page.isChecked('#mode-tolerance'));
  await page.focus('#map');
  const v0 = await page.getAttribute('#map', 'data-view');
  await page.keyboard.press('ArrowRight');
  await page.keyboard.press('+');
  // Both keys' moves, not the first alone: waiting for any change raced the second key.
  await page.waitForFunction((v) => {
    const [lon, , z] = v.split(',').map(Number);
    const [lonNow, , zNow] = document.getElementById('map').dataset.view.split(',').map(Number);
    return lonNow > lon && zNow > z;
  }, v0);
  const [lon0, , z0] = v0.split(',').map(Number);
  const [lon1, , z1] = (await page.getAttribute('#map', 'data-view')).split(',').map(Number);
  assert.ok(lon1 > lon0 && z1 > z0, `${v0} -> ${lon1},${z1}`);
});

test('a fixture file fitted to a tolerance shows the API’s numbers', async () => {
  await page.setInputFiles('#file', BORDER);
  await page.check('#mode-tolerance');
  await page.fill('#tolerance', '500');
  await waitForFit('tolerance_m=500');
  assert.equal(await page.getAttribute('#status', 'data-state'), 'done');
  const url = await page.getAttribute('#request', 'data-url');
  assert.equal(url, '/v1/fit?tolerance_m=500&degree=3');
  const expected = await api(url, readFileSync(BORDER));
  assert.equal(expected.status, 200);
  const fits = JSON.parse(expected.text).features.map((f) => f.properties.fit);
  const rows = await page.$$eval('#features tbody tr', (trs) => trs.map((tr) => Object.fromEntries([...tr.querySelectorAll('td[data-field]')].map((td) => [td.dataset.field, td.textContent.trim()]))));
  assert.equal(rows.length, fits.length);
  const num = (s) => Number(s.replace(/,/g, ''));
  rows.forEach((row, i) => {
    for (const k of ['input_points', 'stored_numbers', 'compression_ratio', 'max_error_m', 'mean_error_m']) {
      assert.equal(num(row[k]), fits[i][k], `feature ${i} ${k}: shown ${row[k]}, API ${fits[i][k]}`);
    }
    assert.equal(row.tolerance_met, fits[i].tolerance_met ? 'yes' : 'no');
    const tw = Object.keys(fits[i]).find((k) => /(two[_-]?way|hausdorff)/i.test(k) && typeof fits[i][k] === 'number');
    if (tw) assert.equal(num(row[tw]), fits[i][tw], `feature ${i} ${tw}`);
  });
  // The points are coloured by a distance the page computed; it is never below zero and, for
  // a fit that meets the tolerance, within it plus the sampling deviation of the output line.
  const maxD = Number(await page.getAttribute('#map', 'data-max-distance-m'));
  const bound = Math.max(...fits.map((f) => f.max_error_m + f.sampling_deviation_m));
  assert.ok(maxD > 0 && maxD <= bound + 0.01, `page distance ${maxD}, bound ${bound}`);
  assert.ok(Number(await page.getAttribute('#map', 'data-drawn-points')) >= 1136);
  assert.ok(Number(await page.getAttribute('#map', 'data-drawn-fitted-runs')) >= 3);
  await shot('02-border-tolerance-500.png');
  await page.evaluate(() => { location.hash = 'view=-104.75,30.1,40'; });
  await page.waitForFunction(() => document.getElementById('map').dataset.view === '-104.7500,30.1000,40.0000');
  await shot('02b-border-zoomed.png');
});

test('the control polygon shows on demand', async () => {
  assert.equal(await page.getAttribute('#map', 'data-drawn-control-points'), '0');
  const before = await page.locator('#map').screenshot();
  await page.check('#show-control');
  await page.waitForFunction(() => Number(document.getElementById('map').dataset.drawnControlPoints) > 0);
  const fit = JSON.parse((await api(await page.getAttribute('#request', 'data-url'), readFileSync(BORDER))).text);
  // A degree-1 spline written once refers to its geometry's positions.
  const controlPoints = (f) => {
    const cp = f.properties.fit.spline.control_points;
    return cp === 'geometry' ? f.geometry.coordinates.length : cp.length;
  };
  const total = fit.features.reduce((s, f) => s + controlPoints(f), 0);
  assert.equal(Number(await page.getAttribute('#map', 'data-drawn-control-points')), total);
  const withPolygon = await page.locator('#map').screenshot();
  assert.ok(!before.equals(withPolygon), 'the map did not change');
  await shot('03-control-polygon.png');
  await page.click('#zoom-fit');
  await page.uncheck('#show-control');
  await page.waitForFunction(() => document.getElementById('map').dataset.drawnControlPoints === '0');
});

test('the downloads are the API’s answer and its compact curves', async () => {
  const url = await page.getAttribute('#request', 'data-url');
  const expected = await api(url, readFileSync(BORDER));
  const [dl] = await Promise.all([page.waitForEvent('download'), page.click('#download-fitted')]);
  assert.equal(dl.suggestedFilename(), 'us_mexico_border_natural_earth.fitted.geojson');
  assert.equal(readFileSync(await dl.path(), 'utf8'), expected.text);
  const [dl2] = await Promise.all([page.waitForEvent('download'), page.click('#download-curves')]);
  assert.equal(dl2.suggestedFilename(), 'us_mexico_border_natural_earth.curves.geojson');
  const curves = readFileSync(await dl2.path(), 'utf8');
  // The fit shown, asked again with carry=spline: the service's own compact curves.
  const compact = await api(`${url}&carry=spline`, readFileSync(BORDER));
  assert.equal(compact.status, 200, compact.text);
  assert.equal(curves, compact.text);
  const c = JSON.parse(curves);
  const e = JSON.parse(expected.text);
  assert.equal(c.features.length, e.features.length);
  c.features.forEach((f, i) => {
    assert.equal(f.geometry, null);
    assert.equal(f.properties.name, e.features[i].properties.name);
    // A compact curve is base64 text (version byte 1: it starts with "AQ"), not a JSON spline.
    assert.equal(typeof f.properties.fit.spline, 'string');
    assert.match(f.properties.fit.spline, /^AQ[A-Za-z0-9+/]*={0,2}$/);
    assert.equal(f.properties.fit.tolerance_met, true);
  });
  assert.ok(curves.length * 2 < expected.text.length, `${curves.length} vs ${expected.text.length}`);
  // The compact file is something /v1/evaluate turns back into lines.
  const back = await api('/v1/evaluate', curves);
  assert.equal(back.status, 200, back.text);
  assert.equal(JSON.parse(back.text).features[2].geometry.type, 'LineString');
  writeFileSync(path.join(SHOTS, 'border.curves.geojson'), curves);
});

test('a file of compact curves is drawn through /v1/evaluate, and a corrupt one is pointed at', async () => {
  const curvesPath = path.join(SHOTS, 'border.curves.geojson');
  const curves = readFileSync(curvesPath, 'utf8');
  const evaluated = [];
  const seen = (r) => { if (r.url().includes('/v1/')) evaluated.push(`${r.method()} ${new URL(r.url()).pathname}`); };
  page.on('request', seen);
  await page.setInputFiles('#file', curvesPath);
  await page.waitForFunction(() => document.getElementById('status').dataset.state === 'done' && document.getElementById('request').dataset.url === '/v1/evaluate');
  page.off('request', seen);
  assert.deepEqual(evaluated, ['POST /v1/evaluate'], 'drawn, not fitted');
  assert.match(await page.innerText('#status'), /Drew 3 of 3 stored curves/);
  // The lines drawn are /v1/evaluate's: as many runs as when the fit itself was shown.
  assert.ok(Number(await page.getAttribute('#map', 'data-drawn-fitted-runs')) >= 3);
  assert.equal(await page.getAttribute('#map', 'data-drawn-input-runs'), '0');
  const fits = JSON.parse(curves).features.map((f) => f.properties.fit);
  const tw = await page.$$eval('#features tbody td[data-field="two_way_distance_m"]', (tds) => tds.map((t) => Number(t.textContent)));
  assert.deepEqual(tw, fits.map((f) => f.two_way_distance_m));
  const names = await page.$$eval('#features tbody th', (ths) => ths.map((t) => t.textContent));
  assert.deepEqual(names, JSON.parse(curves).features.map((f, i) => `${i} · ${f.properties.name}`));
  await shot('06-compact-curves.png');
  // An option change does not send a file of curves to /v1/fit.
  await page.fill('#tolerance', '400');
  await page.waitForTimeout(600);
  assert.match(await page.innerText('#status'), /Drew 3 of 3/);
  await page.fill('#tolerance', '500');
  // The download of a curves file is the file itself.
  const [dl] = await Promise.all([page.waitForEvent('download'), page.click('#download-curves')]);
  assert.equal(readFileSync(await dl.path(), 'utf8'), curves);

  // A corrupt compact curve (version 2) is the service's 422, pointed at.
  const bad = JSON.parse(curves);
  bad.features[1].properties.fit.spline = `Ag${bad.features[1].properties.fit.spline.slice(2)}`;
  await page.setInputFiles('#file', { name: 'bad.curves.geojson', mimeType: 'application/geo+json', buffer: Buffer.from(JSON.stringify(bad)) });
  await page.waitForFunction(() => document.getElementById('status').dataset.state === 'error');
  const text = await page.locator('#problem').innerText();
  assert.match(text, /version 2 at byte 0/);
  assert.match(text, /feature 1.*\/features\/1\/properties\/fit\/spline/s);
  await shot('07-corrupt-compact-curve.png');

  // Back to the border, fitted as before.
  await page.setInputFiles('#file', BORDER);
  await waitForFit('tolerance_m=500');
});

test('a slow fit can be cancelled and leaves no stale numbers', async () => {
  // Hold the next fit request back, as a large file on a busy server would be.
  let release;
  const held = new Promise((ok) => { release = ok; });
  await page.route('**/v1/fit?*', async (route) => { await held; await route.continue().catch(() => {}); });
  try {
    await page.fill('#tolerance', '250');
    await page.waitForFunction(() => document.getElementById('status').dataset.state === 'fitting');
    assert.ok(await page.isVisible('#cancel'));
    await page.click('#cancel');
    await page.waitForFunction(() => document.getElementById('status').dataset.state === 'idle');
    assert.match(await page.innerText('#status'), /cancelled/);
    assert.ok(await page.isHidden('#cancel'));
    assert.equal(await page.locator('#features tbody tr').count(), 0);
  } finally {
    release();
    await page.unroute('**/v1/fit?*');
  }
  // Enter in a field fits again.
  await page.press('#tolerance', 'Enter');
  await waitForFit('tolerance_m=250');
  assert.equal(await page.getAttribute('#status', 'data-state'), 'done');
  await page.fill('#tolerance', '500');
  await waitForFit('tolerance_m=500');
});

test('other options refit on change and a control-point fit is listed the same way', async () => {
  await page.check('#mode-cp');
  await page.fill('#control-points', '20');
  await page.selectOption('#solver', 'gauss-newton');
  await waitForFit('solver=gauss-newton');
  const url = await page.getAttribute('#request', 'data-url');
  assert.equal(url, '/v1/fit?control_points=20&degree=3&knots=geodesic&solver=gauss-newton');
  const fits = JSON.parse((await api(url, readFileSync(BORDER))).text).features.map((f) => f.properties.fit);
  const shown = await page.$$eval('#features tbody td[data-field="max_error_m"]', (tds) => tds.map((t) => Number(t.textContent)));
  assert.deepEqual(shown, fits.map((f) => f.max_error_m));
  // Numbers stored, counted by the page from the spline: 2 per control point, interior knots, degree.
  const stored = await page.$$eval('#features tbody td[data-field="stored_numbers"]', (tds) => tds.map((t) => Number(t.textContent.replace(/,/g, ''))));
  assert.deepEqual(stored, fits.map((f) => 2 * 20 + (f.spline.knots.length - 8) + 1));
});

test('a bad file shows the problem and points at the feature', async () => {
  const doc = JSON.parse(readFileSync(BORDER, 'utf8'));
  doc.features[1].geometry.coordinates[17][1] = 95;
  await page.check('#mode-tolerance');
  await page.setInputFiles('#file', { name: 'bad-latitude.geojson', mimeType: 'application/geo+json', buffer: Buffer.from(JSON.stringify(doc)) });
  await page.waitForFunction(() => document.getElementById('status').dataset.state === 'error');
  const expected = JSON.parse((await api('/v1/fit?tolerance_m=500&degree=3', JSON.stringify(doc))).text);
  assert.equal(expected.pointer, '/features/1/geometry/coordinates/17/1');
  const problem = page.locator('#problem');
  assert.ok(await problem.isVisible());
  assert.equal(await problem.getAttribute('role'), 'alert');
  const text = await problem.innerText();
  assert.ok(text.includes(expected.title), text);
  assert.ok(text.includes(expected.detail), text);
  assert.match(text, /feature 1 \(“USA-Mexico border \(Natural Earth 50m\)”\), position 17, latitude/);
  assert.equal(await page.locator('#features tbody tr').count(), 0, 'no stale numbers');
  assert.ok(await page.isDisabled('#download-fitted'));
  await shot('04-bad-latitude.png');

  await page.setInputFiles('#file', { name: 'truncated.geojson', mimeType: 'application/geo+json', buffer: Buffer.from('{"type": "FeatureCollection", "features": [') });
  await page.waitForFunction(() => document.getElementById('problem').innerText.includes('Malformed JSON'));

  // A bad option points at its control.
  await page.setInputFiles('#file', BORDER);
  await waitForFit('tolerance_m=500');
  await page.check('#mode-cp');
  await page.fill('#control-points', '3');
  await page.waitForFunction(() => document.getElementById('control-points').getAttribute('aria-invalid') === 'true');
  assert.match(await problem.innerText(), /query parameter control_points/);
});

test('files over the server’s limits get a message and are not sent', async () => {
  const limits = await (await fetch(`${BASE}/v1/limits`)).json();
  assert.equal(limits.max_body_bytes, 1048576);
  assert.equal(limits.max_points, 20000);
  let fits = 0;
  const count = (r) => { if (r.url().includes('/v1/fit')) fits++; };
  page.on('request', count);
  const big = Buffer.alloc(limits.max_body_bytes + 1, ' ');
  await page.setInputFiles('#file', { name: 'big.geojson', mimeType: 'application/geo+json', buffer: big });
  await page.waitForFunction(() => document.getElementById('status').dataset.state === 'refused');
  assert.match(await page.innerText('#status'), /1\.0 MiB.*at most 1\.0 MiB.*max_body_bytes/);
  const coords = Array.from({ length: 25000 }, (_, i) => [Number((i * 0.001).toFixed(3)), 0]);
  await page.setInputFiles('#file', { name: 'many.geojson', mimeType: 'application/geo+json', buffer: Buffer.from(JSON.stringify({ type: 'LineString', coordinates: coords })) });
  await page.waitForFunction(() => document.getElementById('status').innerText.includes('25,000'));
  assert.equal(await page.getAttribute('#status', 'data-state'), 'refused');
  assert.match(await page.innerText('#status'), /at most 20,000.*max_points/);
  // Changing an option afterwards must not send the refused file either.
  await page.check('#mode-default');
  await page.check('#mode-tolerance');
  await page.waitForTimeout(300);
  assert.equal(await page.getAttribute('#status', 'data-state'), 'refused');
  page.off('request', count);
  assert.equal(fits, 0, 'a refused file was sent');
  await shot('05-too-large.png');
});

test('drag and drop, the antimeridian and the poles', async () => {
  const fc = {
    type: 'FeatureCollection',
    features: readFileSync(TRACKS_SEQ, 'utf8').split('\x1e').filter((s) => s.trim()).map((s) => JSON.parse(s)),
  };
  const text = JSON.stringify(fc);
  const dt = await page.evaluateHandle((t) => {
    const d = new DataTransfer();
    d.items.add(new File([t], 'tracks.geojson', { type: 'application/geo+json' }));
    return d;
  }, text);
  await page.check('#mode-default');
  await page.dispatchEvent('#map-area', 'drop', { dataTransfer: dt });
  await waitForFit('degree=3&knots=geodesic');
  assert.equal(await page.getAttribute('#status', 'data-state'), 'done', await page.innerText('#status'));
  assert.match(await page.innerText('#input-info'), /tracks\.geojson/);
  // Feature 2 crosses the antimeridian, feature 6 circles the North Pole: look at each.
  for (const [name, lon, lat] of [['06-antimeridian.png', 180, -17], ['07-north-pole.png', 0, 90]]) {
    // zoom 20: about 320 km across
    await page.evaluate(([lo, la]) => { location.hash = `view=${lo},${la},20`; }, [lon, lat]);
    await page.waitForFunction(([lo, la]) => document.getElementById('map').dataset.view.startsWith(`${lo.toFixed(4)},${la.toFixed(4)}`), [lon, lat]);
    assert.ok(Number(await page.getAttribute('#map', 'data-drawn-fitted-runs')) >= 1, name);
    await shot(name);
  }
  // Drag pans.
  const v0 = await page.getAttribute('#map', 'data-view');
  const box = await page.locator('#map').boundingBox();
  await page.mouse.move(box.x + box.width / 2, box.y + box.height / 2);
  await page.mouse.down();
  await page.mouse.move(box.x + box.width / 2 + 120, box.y + box.height / 2 + 40, { steps: 4 });
  await page.mouse.up();
  assert.notEqual(await page.getAttribute('#map', 'data-view'), v0);
});

test('phone width: nothing overflows and the map and controls are usable', async () => {
  await page.setViewportSize({ width: 390, height: 844 });
  await page.setInputFiles('#file', BORDER);
  await page.check('#mode-tolerance');
  await waitForFit('tolerance_m=500');
  const overflow = await page.evaluate(() => document.documentElement.scrollWidth - document.documentElement.clientWidth);
  assert.ok(overflow <= 0, `the page is ${overflow}px wider than the screen`);
  const map = await page.locator('#map').boundingBox();
  assert.ok(map.width <= 390 && map.width >= 300 && map.height >= 300, JSON.stringify(map));
  for (const id of ['#file', '#tolerance', '#degree', '#show-control', '#download-fitted']) {
    const b = await page.locator(id).boundingBox();
    assert.ok(b && b.x >= 0 && b.x + b.width <= 390, `${id} ${JSON.stringify(b)}`);
  }
  await page.screenshot({ path: path.join(SHOTS, '08-phone.png'), fullPage: true });
  assert.deepEqual(pageErrors, []);
});
