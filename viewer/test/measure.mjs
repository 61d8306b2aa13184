#!/usr/bin/env node
// Measures the viewer on a run folder in headless Chromium (software rendering): the time
// `weft view` takes to read the folder, the page's load time (from navigation to the run
// shown), and the playback rate (frames drawn per second over SECONDS of play, with the plain
// and the strain colour maps). Not a test: the figures depend on the machine (docs/viewer.md).
//
//     WEFT_VIEWER_NPM_DIR=build/viewer-npm node viewer/test/measure.mjs WEFT_EXE RUN_DIR [SECONDS] [SCREENSHOT.png]
import {spawn} from 'node:child_process';
import {mkdtempSync, rmSync} from 'node:fs';
import {tmpdir} from 'node:os';
import {join} from 'node:path';
import {loadPuppeteer} from './puppeteer.mjs';

const [weft, runDir, secondsArg, screenshot] = process.argv.slice(2);
if (!weft || !runDir) {
  console.error('usage: measure.mjs WEFT_EXE RUN_DIR [SECONDS] [SCREENSHOT.png]');
  process.exit(2);
}
const seconds = Number(secondsArg || 5);
const chromium = process.env.WEFT_CHROMIUM || '/usr/bin/chromium';
const puppeteer = await loadPuppeteer();

const spawned = Date.now();
const server = spawn(weft, ['view', runDir, '--port', '0', '--no-open'], {stdio: ['ignore', 'pipe', 'inherit']});
let out = '';
const url = await new Promise((resolve, reject) => {
  server.stdout.on('data', (d) => {
    out += d;
    const m = out.match(/serving (http:\S+)/);
    if (m) resolve(m[1]);
  });
  server.on('exit', (code) => reject(new Error(`weft view exited with ${code}`)));
});
const serverSeconds = (Date.now() - spawned) / 1000;
process.stdout.write(out);

const profile = mkdtempSync(join(tmpdir(), 'weft-measure-'));
const browser = await puppeteer.launch({
  executablePath: chromium, headless: true, userDataDir: profile,
  args: ['--no-sandbox', '--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--window-size=1280,800'],
});
try {
  const page = await browser.newPage();
  await page.setViewport({width: 1280, height: 800});
  page.on('console', (m) => { if (m.type() === 'error') console.log(`console error: ${m.text()}`); });
  const before = Date.now();
  await page.goto(url);
  await page.waitForFunction(() => window.weftViewer && (weftViewer.state().loaded || weftViewer.state().error), {timeout: 120000, polling: 20});
  // Until the first frame is drawn.
  await page.waitForFunction(() => weftViewer.state().renders > 0, {polling: 'raf'});
  const loadSeconds = (Date.now() - before) / 1000;
  const state = await page.evaluate(() => weftViewer.state());
  if (state.error) throw new Error(state.error);
  const triangles = state.meshes.reduce((s, m) => s + m.triangles, 0);
  console.log(`renderer: ${state.software ? 'software' : 'GPU'}, antialias ${state.antialias}; frames ${state.frames}; meshes ${state.meshes.map((m) => `${m.name} ${m.vertices} v / ${m.triangles} t`).join(', ')}; ${triangles} triangles`);
  console.log(`weft view read the folder and served in ${serverSeconds.toFixed(2)} s; page load: ${(state.loadedAt / 1000).toFixed(2)} s from the navigation's start to the run shown (of which the page's script ${(state.loadMs / 1000).toFixed(2)} s: fetching run/data.bin and building the meshes); ${loadSeconds.toFixed(2)} s from puppeteer's goto to the first frame drawn`);
  for (const map of ['plain', 'strain']) {
    await page.select('#colour', map);
    await page.click('#play');
    await new Promise((r) => setTimeout(r, 500));
    const r0 = await page.evaluate(() => [weftViewer.state().renders, weftViewer.state().time, performance.now()]);
    await new Promise((r) => setTimeout(r, seconds * 1000));
    const r1 = await page.evaluate(() => [weftViewer.state().renders, weftViewer.state().time, performance.now()]);
    await page.click('#play');
    const fps = (r1[0] - r0[0]) / ((r1[2] - r0[2]) / 1000);
    const s1 = await page.evaluate(() => weftViewer.state());
    console.log(`playback, colour ${map}: ${fps.toFixed(1)} frames drawn per second over ${seconds} s ` +
                `(per frame: ${s1.updateMs.toFixed(1)} ms updating the meshes, ${s1.renderMs.toFixed(1)} ms in three.js's render call)`);
  }
  if (screenshot) {
    await page.evaluate(() => weftViewer.setTime(weftViewer.state().frames > 1 ? 2.5 : 0));
    await new Promise((r) => setTimeout(r, 500));
    await page.screenshot({path: screenshot});
  }
} finally {
  await browser.close();
  rmSync(profile, {recursive: true, force: true});
  server.kill('SIGTERM');
}
