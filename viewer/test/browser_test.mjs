#!/usr/bin/env node
// The viewer in a real browser: a short `weft run` (a small sheet falling onto a sphere, with
// PLY frames and the glb), `weft view` on a free port, and Debian's Chromium driven headless
// by puppeteer-core. Checks that the page loads the run's frames and vertices, plays (the time
// advances), pauses, scrubs (the slider shows that frame's positions), switches the colour
// map, logs no console error, and that `weft view` stops cleanly on SIGTERM; and, on a second
// run (an OBJ cloth at rest whose texture coordinates are in units of its scene's uv_scale),
// that the strain is 0 with the run's uv_scale.
//
//     node viewer/test/browser_test.mjs WEFT_EXE SCRATCH_DIR
//
// Exit status 0 passed, 1 failed, 77 skipped (no Chromium: set WEFT_CHROMIUM to its path).
// puppeteer-core comes from $WEFT_VIEWER_NPM_DIR/node_modules (the build's viewer-npm, which
// ctest passes), else viewer/node_modules.
import {spawn, spawnSync} from 'node:child_process';
import {existsSync, mkdirSync, readFileSync, readdirSync, rmSync, writeFileSync} from 'node:fs';
import {join} from 'node:path';
import {loadPuppeteer} from './puppeteer.mjs';

const [weft, scratch] = process.argv.slice(2);
if (!weft || !scratch) {
  console.error('usage: browser_test.mjs WEFT_EXE SCRATCH_DIR');
  process.exit(1);
}
const chromium = process.env.WEFT_CHROMIUM || '/usr/bin/chromium';
if (!existsSync(chromium)) {
  console.log(`skipped: no Chromium at ${chromium} (Debian package chromium; or set WEFT_CHROMIUM)`);
  process.exit(77);
}
const puppeteer = await loadPuppeteer();

const started = Date.now();
const failures = [];
function check(condition, what) {
  if (!condition) failures.push(what);
  console.log(`${condition ? 'ok  ' : 'FAIL'} ${what}`);
}

rmSync(scratch, {recursive: true, force: true});
mkdirSync(scratch, {recursive: true});
const scenePath = join(scratch, 'scene.json');
writeFileSync(scenePath, JSON.stringify({
  weft_scene: 1,
  description: 'viewer test: a small sheet falling onto a sphere',
  duration: 0.3,
  frame_interval: 0.02,
  integrator: {method: 'bdf2', dt: 0.005},
  cloth: {
    mesh: {grid: {size: [0.6, 0.6], vertices: [13, 13]}},
    placement: {rotation_deg: [-90, 0, 0], translation: [-0.3, 0.45, 0.3]},
    material: 'cotton',
  },
  colliders: [{type: 'sphere', centre: [0, 0.2, 0], radius: 0.2, thickness: 0.003, friction: 0.3}],
}));
const runDir = join(scratch, 'run');
const run = spawnSync(weft, ['run', scenePath, '--out', runDir, '--format', 'ply,glb'], {encoding: 'utf8'});
if (run.status !== 0) {
  console.error(`weft run failed (exit ${run.status}):\n${run.stderr}`);
  process.exit(1);
}
const summary = JSON.parse(readFileSync(join(runDir, 'summary.json'), 'utf8'));
const frameFiles = readdirSync(join(runDir, 'frames')).filter((f) => /^frame_\d+\.ply$/.test(f)).sort();
const colliderFiles = readdirSync(join(runDir, 'frames')).filter((f) => /^(body|collider)\d+_00000\.obj$/.test(f)).sort();
const energyTimes = readFileSync(join(runDir, 'energy.csv'), 'utf8').trim().split('\n').slice(1).map((l) => Number(l.split(',')[0]));

function plyVertices(file) {
  const lines = readFileSync(file, 'utf8').split('\n');
  const count = Number(lines.find((l) => l.startsWith('element vertex')).split(' ')[2]);
  const start = lines.indexOf('end_header') + 1;
  return lines.slice(start, start + count).map((l) => l.split(' ').slice(0, 3).map(Number));
}
function objVertexCount(file) {
  return readFileSync(file, 'utf8').split('\n').filter((l) => l.startsWith('v ')).length;
}

// `weft view DIR` on a port the system picks; its URL is on the second line it prints.
async function startView(dir) {
  const server = spawn(weft, ['view', dir, '--port', '0', '--no-open'], {stdio: ['ignore', 'pipe', 'pipe']});
  const view = {server, out: '', err: ''};
  server.stderr.on('data', (d) => { view.err += d; });
  view.exited = new Promise((resolve) => server.on('exit', (code, signal) => resolve({code, signal})));
  view.url = await new Promise((resolve, reject) => {
    const timer = setTimeout(() => reject(new Error(`weft view printed no URL in 30 s: ${view.out}${view.err}`)), 30000);
    server.stdout.on('data', (d) => {
      view.out += d;
      const m = view.out.match(/serving (http:\/\/127\.0\.0\.1:\d+\/)/);
      if (m) { clearTimeout(timer); resolve(m[1]); }
    });
    server.on('exit', (code) => reject(new Error(`weft view exited (${code}) before serving: ${view.err}`)));
  });
  return view;
}
const view = await startView(runDir);
const url = view.url;

// A second run: an OBJ cloth at rest (no gravity) whose texture coordinates are in units of
// 2.5 m (the scene's mesh.uv_scale), so its strain is 0 only when read times 2.5.
let obj = '';
for (let j = 0; j < 3; ++j) for (let i = 0; i < 3; ++i) obj += `v ${0.25 * i} ${0.25 * j} 0\n`;
for (let j = 0; j < 3; ++j) for (let i = 0; i < 3; ++i) obj += `vt ${0.1 * i} ${0.1 * j}\n`;
for (let j = 0; j < 2; ++j) for (let i = 0; i < 2; ++i) {
  const [a, b, c, d] = [3 * j + i + 1, 3 * j + i + 2, 3 * j + i + 5, 3 * j + i + 4];
  obj += `f ${a}/${a} ${b}/${b} ${c}/${c}\nf ${a}/${a} ${c}/${c} ${d}/${d}\n`;
}
writeFileSync(join(scratch, 'square.obj'), obj);
const restScenePath = join(scratch, 'rest.json');
writeFileSync(restScenePath, JSON.stringify({
  weft_scene: 1, duration: 0.04, frame_interval: 0.02, gravity: [0, 0, 0],
  integrator: {method: 'implicit-midpoint', dt: 0.02},
  cloth: {mesh: {obj: 'square.obj', uv_scale: 2.5}, material: 'cotton'},
}));
const restDir = join(scratch, 'rest');
const restRun = spawnSync(weft, ['run', restScenePath, '--out', restDir, '--format', 'obj'], {encoding: 'utf8'});
if (restRun.status !== 0) {
  console.error(`weft run of the OBJ cloth failed (exit ${restRun.status}):\n${restRun.stderr}`);
  process.exit(1);
}
const restView = await startView(restDir);

const browser = await puppeteer.launch({
  executablePath: chromium,
  headless: true,
  userDataDir: join(scratch, 'chromium-profile'),
  // --no-sandbox: Chromium's sandbox refuses to run as root (containers, CI). WebGL runs on
  // SwiftShader, Chromium's software renderer, on machines without a GPU.
  args: ['--no-sandbox', '--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--window-size=1200,800'],
});
const consoleErrors = [];
try {
  const page = await browser.newPage();
  await page.setViewport({width: 1200, height: 800});
  page.on('console', (m) => { if (m.type() === 'error') consoleErrors.push(m.text()); });
  page.on('pageerror', (e) => consoleErrors.push(`page error: ${e.message}`));
  page.on('requestfailed', (r) => consoleErrors.push(`request failed: ${r.url()}`));
  await page.goto(url, {waitUntil: 'load'});
  await page.waitForFunction(() => window.weftViewer && (weftViewer.state().loaded || weftViewer.state().error), {timeout: 30000});
  let s = await page.evaluate(() => weftViewer.state());
  check(s.error === null, `the page loaded the run (error: ${s.error})`);
  check(s.frames === frameFiles.length && s.frames === energyTimes.length,
        `frames: ${s.frames}, the run wrote ${frameFiles.length} (energy.csv rows: ${energyTimes.length})`);
  check(s.meshes.length === 1 + colliderFiles.length, `meshes: ${s.meshes.length}, the cloth and ${colliderFiles.length} collider(s)`);
  check(s.meshes[0].vertices === summary.vertices && s.meshes[0].triangles === summary.triangles,
        `cloth: ${s.meshes[0].vertices} vertices, ${s.meshes[0].triangles} triangles (summary: ${summary.vertices}, ${summary.triangles})`);
  colliderFiles.forEach((f, k) => {
    const expected = objVertexCount(join(runDir, 'frames', f));
    check(s.meshes[k + 1].vertices === expected, `${s.meshes[k + 1].name}: ${s.meshes[k + 1].vertices} vertices, ${f} has ${expected}`);
  });

  // Play, then pause.
  const t0 = s.time;
  await page.click('#play');
  await page.waitForFunction((t) => weftViewer.state().time > t + 0.02, {timeout: 10000}, t0);
  s = await page.evaluate(() => weftViewer.state());
  check(s.playing && s.time > t0, `playing: the time went from ${t0} to ${s.time.toFixed(3)} s`);
  await page.click('#play');
  const paused = await page.evaluate(() => weftViewer.state().time);
  await new Promise((r) => setTimeout(r, 300));
  s = await page.evaluate(() => weftViewer.state());
  check(!s.playing && s.time === paused, `paused: the time stays at ${paused.toFixed(3)} s`);

  // Scrub to a frame in the middle: the cloth shows that frame's positions.
  const k = Math.floor(frameFiles.length / 2);
  await page.evaluate((k) => {
    const slider = document.getElementById('scrub');
    slider.value = String(k);
    slider.dispatchEvent(new Event('input', {bubbles: true}));
  }, k);
  s = await page.evaluate(() => weftViewer.state());
  check(s.frame === k && Math.abs(s.time - energyTimes[k]) < 1e-6, `scrubbed to frame ${s.frame} at ${s.time} s (expected ${k} at ${energyTimes[k]} s)`);
  const ply = plyVertices(join(runDir, 'frames', frameFiles[k]));
  const ply0 = plyVertices(join(runDir, 'frames', frameFiles[0]));
  let worst = 0, moved = 0;
  for (const i of [0, Math.floor(ply.length / 2), ply.length - 1]) {
    const shown = await page.evaluate((i) => weftViewer.vertex(0, i), i);
    for (let d = 0; d < 3; ++d) {
      worst = Math.max(worst, Math.abs(shown[d] - ply[i][d]));
      moved = Math.max(moved, Math.abs(ply[i][d] - ply0[i][d]));
    }
  }
  check(worst < 1e-5 && moved > 1e-3, `frame ${k}'s positions shown (largest difference from its PLY file ${worst.toExponential(2)} m; it moved ${moved.toFixed(3)} m from frame 0)`);

  // Colour maps.
  check(await page.evaluate(() => weftViewer.distinctClothColours()) === 1, 'plain: one colour');
  await page.select('#colour', 'strain');
  s = await page.evaluate(() => weftViewer.state());
  const strainColours = await page.evaluate(() => weftViewer.distinctClothColours());
  const legend = await page.evaluate(() => !document.getElementById('legend').hidden && document.getElementById('legend-title').textContent);
  check(s.colourMap === 'strain' && strainColours > 1 && /strain/.test(legend), `strain: ${strainColours} colours, legend '${legend}'`);
  await page.select('#colour', 'viscosity');
  s = await page.evaluate(() => weftViewer.state());
  const viscosityLegend = await page.evaluate(() => document.getElementById('legend-title').textContent);
  check(s.colourMap === 'viscosity' && /added viscosity/.test(viscosityLegend), `viscosity: legend '${viscosityLegend}'`);
  await page.select('#colour', 'plain');
  check(await page.evaluate(() => weftViewer.distinctClothColours()) === 1 && await page.evaluate(() => document.getElementById('legend').hidden),
        'back to plain: one colour, no legend');
  const summaryRows = await page.evaluate(() => document.querySelectorAll('#summary tr').length);
  check(summaryRows > 5, `summary table: ${summaryRows} rows`);

  // The OBJ cloth at rest: no strain with the run's uv_scale.
  const restPage = await browser.newPage();
  restPage.on('console', (m) => { if (m.type() === 'error') consoleErrors.push(m.text()); });
  restPage.on('pageerror', (e) => consoleErrors.push(`page error: ${e.message}`));
  await restPage.goto(restView.url, {waitUntil: 'load'});
  await restPage.waitForFunction(() => window.weftViewer && (weftViewer.state().loaded || weftViewer.state().error), {timeout: 30000});
  await restPage.select('#colour', 'strain');
  const rest = await restPage.evaluate(() => weftViewer.strain(weftViewer.state().frames - 1));
  check(rest.uvScale === 2.5 && rest.largest < 1e-4,
        `an OBJ cloth at rest with uv_scale 2.5: uv_scale ${rest.uvScale}, largest |strain| ${rest.largest.toExponential(2)}`);
} finally {
  await browser.close();
}
check(consoleErrors.length === 0, `no console errors${consoleErrors.length ? `: ${consoleErrors.join(' | ')}` : ''}`);
for (const v of [view, restView]) {
  v.server.kill('SIGTERM');
  const {code} = await v.exited;
  check(code === 0, `weft view stopped on SIGTERM with exit status ${code}${v.err ? `: ${v.err}` : ''}`);
}
console.log(`${failures.length ? 'FAILED' : 'passed'} in ${((Date.now() - started) / 1000).toFixed(1)} s`);
process.exit(failures.length ? 1 : 0);
