// weft's viewer (docs/viewer.md): plays a run served by `weft view`. It loads run/manifest.json
// and run/data.bin (every mesh's triangles, texture coordinates, positions per frame and added
// viscosity, laid out as the manifest says), run/summary.json and run/energy.csv, then shows
// the cloth and colliders, the energies with a cursor at the current time, and the summary.
import * as THREE from 'three';
import {OrbitControls} from 'three/addons/controls/OrbitControls.js';
import {strainField} from './strain.js';
import {makeAppearance, srgbEncodeByte} from './appearance.js';
import appearanceTable from '../../src/render/appearance.json';
import {EnergyChart} from './energy.js';
import {showSummary} from './summary.js';

const $ = (id) => document.getElementById(id);
const scriptStartedAt = performance.now();

// The colour maps, colours and shading of `weft render` (src/render/appearance.json).
const look = makeAppearance(appearanceTable);

const viewer = {
  loaded: false,
  error: null,
  manifest: null,
  meshes: [],      // {name, vertices, frames, positions (all frames), viscosity, viscosityFrames, texcoords, indices, geometry, object}
  times: [],
  time: 0,
  frame: 0,
  playing: false,
  speed: 1,
  colourMap: 'plain',
  loadMs: 0,       // from the script's start to the run shown
  loadedAt: 0,     // ms from the navigation's start to the run shown
  renders: 0,
  fps: 0,
  updateMs: 0,     // time spent updating the meshes, per frame shown (running mean)
  renderMs: 0,     // time spent in three.js's render call, per frame drawn (running mean)
};

// What the tests (and a curious user, from the console) can read of the page.
window.weftViewer = {
  state() {
    return {
      loaded: viewer.loaded, error: viewer.error, frames: viewer.times.length, time: viewer.time, frame: viewer.frame,
      playing: viewer.playing, speed: viewer.speed, colourMap: viewer.colourMap, loadMs: viewer.loadMs,
      loadedAt: viewer.loadedAt, scriptStartedAt, rendererReadyAt, software, antialias, renders: viewer.renders, fps: viewer.fps, updateMs: viewer.updateMs, renderMs: viewer.renderMs,
      positionsSource: viewer.manifest && viewer.manifest.positions_source,
      meshes: viewer.meshes.map((m) => ({name: m.name, vertices: m.vertices, triangles: m.indices.length / 3, frames: m.frames})),
    };
  },
  /** The position shown now of vertex `i` of mesh `meshIndex`. */
  vertex(meshIndex, i) {
    const a = viewer.meshes[meshIndex].geometry.attributes.position.array;
    return [a[3 * i], a[3 * i + 1], a[3 * i + 2]];
  },
  /** The number of distinct colours (to 1/256) among the cloth's vertices. */
  distinctClothColours() {
    const c = viewer.meshes[0].geometry.attributes.color.array;
    const seen = new Set();
    for (let i = 0; i < c.length; i += 3) seen.add(`${Math.round(c[i] * 255)},${Math.round(c[i + 1] * 255)},${Math.round(c[i + 2] * 255)}`);
    return seen.size;
  },
  setTime: (t) => setTime(t),
  /** The run's uv_scale, the strain map's scale and the largest |strain| at frame `frame` (the strain computed if need be). */
  strain(frame) {
    ensureStrain();
    const n = viewer.meshes[0].vertices;
    let largest = 0;
    for (const v of strain.perFrame.subarray(frame * n, (frame + 1) * n)) largest = Math.max(largest, Math.abs(v));
    return {uvScale: viewer.manifest.uv_scale, scale: colourScale.strain, largest};
  },
};

// ---------------------------------------------------------------------------------------------
// Scene

// Multisampling costs a software renderer (SwiftShader, llvmpipe: machines without a GPU) about
// a third of its frame rate, so it is on only for a GPU; ?antialias=1 or 0 says otherwise.
function softwareRenderer() {
  const gl = document.createElement('canvas').getContext('webgl2');
  if (!gl) return false;
  const info = gl.getExtension('WEBGL_debug_renderer_info');
  const name = info ? String(gl.getParameter(info.UNMASKED_RENDERER_WEBGL)) : '';
  const lose = gl.getExtension('WEBGL_lose_context');
  if (lose) lose.loseContext();
  return /swiftshader|llvmpipe|softpipe|software/i.test(name);
}
const antialiasParameter = new URLSearchParams(location.search).get('antialias');
const software = softwareRenderer();
const antialias = antialiasParameter === null ? !software : antialiasParameter === '1';

const canvas = $('scene');
const renderer = new THREE.WebGLRenderer({canvas, antialias});
renderer.setPixelRatio(window.devicePixelRatio);
const scene = new THREE.Scene();
const rendererReadyAt = performance.now();
scene.background = new THREE.Color(0xdfe3e8);
const camera = new THREE.PerspectiveCamera(40, 1, 0.01, 1000);
const controls = new OrbitControls(camera, canvas);
let needsRender = true;
controls.addEventListener('change', () => { needsRender = true; });

// The shading of `weft render` (src/render/picture.cpp, constants from appearance.json): a sky
// and ground ambient, a key light set from the camera (so every view is lit alike), a headlight
// at the eye and a Blinn highlight from the key light, in linear RGB, two-sided: the cloth's
// back side in its back colour (a colour map's colours darkened), each side's normal turned
// towards the eye. A collider's normal further from its face's than the crease angle gives way
// to the face's (a box keeps flat faces).
const shadingVertex = `
varying vec3 vWorld;
varying vec3 vNormal;
varying vec3 vColour;
void main() {
  vec4 world = modelMatrix * vec4(position, 1.0);
  vWorld = world.xyz;
  vNormal = mat3(modelMatrix) * normal;
#ifdef USE_COLOR
  vColour = color;
#else
  vColour = vec3(1.0);
#endif
  gl_Position = projectionMatrix * viewMatrix * world;
}`;
const shadingFragment = `
uniform vec3 frontColour, backColour, keyLight;
uniform float ambient, ambientUp, keyStrength, headlight, highlight, shininess, backFactor, creaseCosine;
uniform bool coloured, creases;
varying vec3 vWorld;
varying vec3 vNormal;
varying vec3 vColour;
void main() {
  vec3 v = normalize(cameraPosition - vWorld);
  vec3 n = (gl_FrontFacing ? 1.0 : -1.0) * normalize(vNormal);
  if (creases) {
    vec3 face = normalize(cross(dFdx(vWorld), dFdy(vWorld)));
    if (dot(face, v) < 0.0) face = -face;
    if (dot(n, face) <= creaseCosine) n = face;
  }
  if (dot(n, v) < 0.0) n = normalize(n - 1.01 * dot(n, v) * v);
  vec3 base = coloured ? vColour * (gl_FrontFacing ? 1.0 : backFactor) : (gl_FrontFacing ? frontColour : backColour);
  float nl = dot(n, keyLight);
  float light = ambient + ambientUp * n.y + keyStrength * max(0.0, nl) + headlight * max(0.0, dot(n, v));
  float specular = nl > 0.0 ? highlight * pow(max(0.0, dot(n, normalize(keyLight + v))), shininess) : 0.0;
  gl_FragColor = vec4(base * light + vec3(specular), 1.0);
  #include <colorspace_fragment>
}`;
const keyLight = new THREE.Vector3();

function surfaceMaterial(isCloth) {
  const sh = look.shading;
  const surface = isCloth ? sh.cloth : sh.collider;
  const colour = (c) => new THREE.Vector3(...c);
  return new THREE.ShaderMaterial({
    vertexShader: shadingVertex,
    fragmentShader: shadingFragment,
    vertexColors: isCloth,
    side: THREE.DoubleSide,
    polygonOffset: !isCloth, polygonOffsetFactor: 1, polygonOffsetUnits: 1,
    uniforms: {
      frontColour: {value: colour(isCloth ? look.clothFront : look.collider)},
      backColour: {value: colour(isCloth ? look.clothBack : look.collider)},
      keyLight: {value: keyLight},
      ambient: {value: sh.ambient}, ambientUp: {value: sh.ambient_up}, keyStrength: {value: sh.key},
      headlight: {value: sh.headlight}, highlight: {value: surface.highlight}, shininess: {value: surface.shininess},
      backFactor: {value: sh.coloured_back_factor}, creaseCosine: {value: sh.collider_crease_cosine},
      coloured: {value: false}, creases: {value: !isCloth},
    },
  });
}

// The key light from the camera's axes, as picture.cpp's lights_for.
function updateKeyLight() {
  const sh = look.shading, d = sh.key_direction;
  const forward = camera.getWorldDirection(new THREE.Vector3());
  const right = new THREE.Vector3().crossVectors(forward, camera.up).normalize();
  keyLight.copy(right).multiplyScalar(d.right).add(new THREE.Vector3(0, d.up, 0)).addScaledVector(forward, -d.back);
  keyLight.y = Math.max(keyLight.y, sh.key_min_elevation * keyLight.length());
  keyLight.normalize();
}

function resize() {
  const r = canvas.parentElement.getBoundingClientRect();
  renderer.setSize(Math.max(1, r.width), Math.max(1, r.height), false);
  camera.aspect = Math.max(1, r.width) / Math.max(1, r.height);
  camera.updateProjectionMatrix();
  needsRender = true;
}
new ResizeObserver(resize).observe(canvas.parentElement);

function status(text, isError = false) {
  const el = $('status');
  el.textContent = text;
  el.classList.toggle('error', isError);
  el.hidden = !text;
}

function fail(message) {
  viewer.error = message;
  status(message, true);
  console.error(`weft view: ${message}`);
}

// ---------------------------------------------------------------------------------------------
// Loading

async function fetchOk(path) {
  const response = await fetch(path);
  if (!response.ok) throw new Error(`${path}: HTTP ${response.status}`);
  return response;
}

async function load() {
  const start = performance.now();
  const manifest = await (await fetchOk('run/manifest.json')).json();
  const files = manifest.run_files || [];
  const [data, summaryText, energyText] = await Promise.all([
    fetchOk('run/data.bin').then((r) => r.arrayBuffer()),
    files.includes('summary.json') ? fetchOk('run/summary.json').then((r) => r.text()) : null,
    files.includes('energy.csv') ? fetchOk('run/energy.csv').then((r) => r.text()) : null,
  ]);
  if (data.byteLength !== manifest.data_bytes)
    throw new Error(`run/data.bin: ${data.byteLength} bytes, the manifest says ${manifest.data_bytes}`);
  viewer.manifest = manifest;
  viewer.times = manifest.times;
  $('title').textContent = manifest.folder;
  document.title = `weft view: ${manifest.folder}`;

  for (const [k, m] of manifest.meshes.entries()) {
    const isCloth = k === 0;
    const mesh = {
      name: m.name, vertices: m.vertices, frames: m.frames,
      indices: new Uint32Array(data, m.indices_offset, 3 * m.triangles),
      positions: new Float32Array(data, m.positions_offset, 3 * m.vertices * m.frames),
      texcoords: m.texcoords_offset === null ? null : new Float32Array(data, m.texcoords_offset, 2 * m.vertices),
      viscosity: m.viscosity_offset === null ? null : new Float32Array(data, m.viscosity_offset, m.vertices * m.viscosity_frames),
      viscosityFrames: m.viscosity_frames,
    };
    const geometry = new THREE.BufferGeometry();
    const position = new THREE.BufferAttribute(new Float32Array(3 * m.vertices), 3);
    position.setUsage(m.frames > 1 ? THREE.DynamicDrawUsage : THREE.StaticDrawUsage);
    position.array.set(mesh.positions.subarray(0, 3 * m.vertices));
    geometry.setAttribute('position', position);
    geometry.setIndex(new THREE.BufferAttribute(mesh.indices, 1));
    geometry.computeVertexNormals();
    let material;
    if (isCloth) {
      const colour = new THREE.BufferAttribute(new Float32Array(3 * m.vertices), 3);
      colour.setUsage(THREE.DynamicDrawUsage);
      geometry.setAttribute('color', colour);
      material = surfaceMaterial(true);
    } else {
      material = surfaceMaterial(false);
    }
    mesh.geometry = geometry;
    mesh.object = new THREE.Mesh(geometry, material);
    mesh.object.name = m.name;
    scene.add(mesh.object);
    viewer.meshes.push(mesh);
  }
  setUpColourMaps();
  frameCamera();
  if (energyText !== null) energyChart = new EnergyChart($('energy'), $('energy-keys'), energyText, (t) => seek(t));
  showSummary($('summary'), $('summary-json'), summaryText);

  const scrub = $('scrub');
  scrub.max = String(viewer.times.length - 1);
  scrub.disabled = false;
  $('play').disabled = viewer.times.length < 2;
  viewer.loaded = true;
  setTime(viewer.times[0]);
  viewer.loadMs = performance.now() - start;
  viewer.loadedAt = performance.now();
  status('');
}

// The camera looks at the cloth over the run, the bodies, and the other colliders not much
// larger than the cloth (a floor plane would otherwise push the cloth out of sight).
function frameCamera() {
  const clothBox = new THREE.Box3();
  const cloth = viewer.meshes[0];
  const p = new THREE.Vector3();
  const step = Math.max(1, Math.floor(cloth.frames / 20));
  for (let f = 0; f < cloth.frames; f += step)
    for (let i = 0; i < cloth.vertices; ++i) clothBox.expandByPoint(p.fromArray(cloth.positions, 3 * (f * cloth.vertices + i)));
  const box = clothBox.clone();
  const clothSize = clothBox.getSize(new THREE.Vector3()).length();
  for (const m of viewer.meshes.slice(1)) {
    m.geometry.computeBoundingBox();
    if (m.name.startsWith('body') || m.geometry.boundingBox.getSize(new THREE.Vector3()).length() < 2 * clothSize)
      box.union(m.geometry.boundingBox);
  }
  const centre = box.getCenter(new THREE.Vector3());
  const radius = Math.max(0.05, 0.5 * box.getSize(new THREE.Vector3()).length());
  const distance = radius / Math.sin(THREE.MathUtils.degToRad(camera.fov / 2));
  camera.position.copy(centre).add(new THREE.Vector3(0.55, 0.45, 1).normalize().multiplyScalar(distance));
  camera.near = distance / 100;
  camera.far = distance * 100;
  camera.updateProjectionMatrix();
  controls.target.copy(centre);
  controls.update();
}

// ---------------------------------------------------------------------------------------------
// Colour maps: plain, added viscosity (per frame from PLY frames, or each vertex's peak from
// the glb), strain (largest principal stretch of each triangle against the texture
// coordinates, averaged to the vertices).

let colourScale = {viscosity: 0, strain: 0};
let strain = null;  // {perFrame: Float32Array(frames * vertices)} once computed

function setUpColourMaps() {
  const cloth = viewer.meshes[0];
  const select = $('colour');
  const viscosityOption = select.querySelector('option[value=viscosity]');
  const strainOption = select.querySelector('option[value=strain]');
  viscosityOption.disabled = !cloth.viscosity;
  viscosityOption.title = cloth.viscosity ? '' : 'the run wrote no added viscosity: run with --format ply or glb';
  if (cloth.viscosity) {
    let max = 0;
    for (const v of cloth.viscosity) max = Math.max(max, v);
    colourScale.viscosity = max;
    if (cloth.viscosityFrames === 1) viscosityOption.textContent = 'added viscosity (peak over the run)';
  }
  strainOption.disabled = !cloth.texcoords;
  strainOption.title = cloth.texcoords ? '' : 'the run wrote no texture coordinates: run with --format obj or glb';
}

function ensureStrain() {
  if (strain) return;
  const cloth = viewer.meshes[0];
  const perFrame = new Float32Array(cloth.frames * cloth.vertices);
  for (let f = 0; f < cloth.frames; ++f)
    strainField(cloth.positions.subarray(3 * f * cloth.vertices, 3 * (f + 1) * cloth.vertices), cloth.texcoords, cloth.indices,
                viewer.manifest.uv_scale ?? 1, perFrame.subarray(f * cloth.vertices, (f + 1) * cloth.vertices));
  strain = {perFrame};
  colourScale.strain = look.strainScale(perFrame);
}

// The ramps give linear RGB (vertex colours, which the shading lights); CSS takes sRGB.
function cssGradient(ramp, from, to) {
  const out = [0, 0, 0], stops = [];
  for (let k = 0; k <= 16; ++k) {
    ramp(from + (to - from) * k / 16, out);
    stops.push(`rgb(${out.map(srgbEncodeByte).join(',')})`);
  }
  return `linear-gradient(to right, ${stops.join(', ')})`;
}

function showLegend() {
  const legend = $('legend');
  legend.hidden = viewer.colourMap === 'plain';
  if (viewer.colourMap === 'viscosity') {
    $('legend-title').textContent = viewer.meshes[0].viscosityFrames === 1 ? 'added viscosity, peak over the run (N s/m)'
                                                                            : 'added viscosity (N s/m)';
    $('legend-bar').style.background = cssGradient(look.sequential, 0, 1);
    $('legend-min').textContent = '0';
    $('legend-max').textContent = colourScale.viscosity.toPrecision(3);
  } else if (viewer.colourMap === 'strain') {
    $('legend-title').textContent = 'strain: largest principal stretch - 1 (%)';
    $('legend-bar').style.background = cssGradient(look.diverging, -1, 1);
    $('legend-min').textContent = (-100 * colourScale.strain).toPrecision(3);
    $('legend-max').textContent = `+${(100 * colourScale.strain).toPrecision(3)}`;
  }
}

function colourCloth(frame) {
  const cloth = viewer.meshes[0];
  const attribute = cloth.geometry.attributes.color;
  const c = attribute.array, rgb = [0, 0, 0];
  const n = cloth.vertices;
  if (viewer.colourMap === 'viscosity' && cloth.viscosity) {
    const base = cloth.viscosityFrames > 1 ? Math.min(frame, cloth.viscosityFrames - 1) * n : 0;
    const scale = colourScale.viscosity > 0 ? 1 / colourScale.viscosity : 0;
    for (let i = 0; i < n; ++i) {
      look.sequential(cloth.viscosity[base + i] * scale, rgb);
      c[3 * i] = rgb[0], c[3 * i + 1] = rgb[1], c[3 * i + 2] = rgb[2];
    }
  } else if (viewer.colourMap === 'strain' && cloth.texcoords) {
    ensureStrain();
    const values = strain.perFrame.subarray(frame * n, (frame + 1) * n);
    const scale = colourScale.strain > 0 ? 1 / colourScale.strain : 0;
    for (let i = 0; i < n; ++i) {
      look.diverging(values[i] * scale, rgb);
      c[3 * i] = rgb[0], c[3 * i + 1] = rgb[1], c[3 * i + 2] = rgb[2];
    }
  } else {
    // White: the shader then takes the cloth's own front and back colours.
    c.fill(1);
  }
  cloth.object.material.uniforms.coloured.value = viewer.colourMap !== 'plain';
  attribute.needsUpdate = true;
}

function setColourMap(name) {
  const option = $('colour').querySelector(`option[value=${name}]`);
  if (!option || option.disabled) name = 'plain';
  viewer.colourMap = name;
  $('colour').value = name;
  colourCloth(viewer.frame);
  showLegend();
  needsRender = true;
}

// ---------------------------------------------------------------------------------------------
// Time

let energyChart = null;
let colouredFrame = -1;

// The last frame at or before `t`.
function frameAt(t) {
  const times = viewer.times;
  let lo = 0, hi = times.length - 1;
  if (t >= times[hi]) return hi;
  while (hi - lo > 1) {
    const mid = (lo + hi) >> 1;
    if (times[mid] <= t) lo = mid; else hi = mid;
  }
  return lo;
}

// Shows the run at time `t`: positions blended linearly between the frames around it (as the
// glb's animation does), colours of the frame at or before it.
function setTime(t) {
  const began = performance.now();
  const times = viewer.times;
  t = Math.min(times[times.length - 1], Math.max(times[0], t));
  const k = frameAt(t);
  const next = Math.min(k + 1, times.length - 1);
  const a = next > k ? (t - times[k]) / (times[next] - times[k]) : 0;
  for (const m of viewer.meshes) {
    if (m.frames < 2 && viewer.loaded && m.shown) continue;
    const n3 = 3 * m.vertices;
    const out = m.geometry.attributes.position.array;
    const f0 = Math.min(k, m.frames - 1), f1 = Math.min(next, m.frames - 1);
    const x0 = m.positions.subarray(f0 * n3, (f0 + 1) * n3);
    if (a === 0 || f0 === f1) {
      out.set(x0);
    } else {
      const x1 = m.positions.subarray(f1 * n3, (f1 + 1) * n3);
      for (let i = 0; i < n3; ++i) out[i] = x0[i] + a * (x1[i] - x0[i]);
    }
    m.geometry.attributes.position.needsUpdate = true;
    m.geometry.computeVertexNormals();
    m.shown = true;
  }
  viewer.time = t;
  viewer.frame = k;
  if (colouredFrame !== k || viewer.colourMap === 'plain') {
    colourCloth(k);
    colouredFrame = k;
  }
  $('scrub').value = String(k);
  $('time').textContent = `t = ${t.toFixed(3)} s   frame ${k} / ${times.length - 1}`;
  if (energyChart) energyChart.cursor(t);
  needsRender = true;
  viewer.updateMs += 0.1 * (performance.now() - began - viewer.updateMs);
}

function seek(t) {
  setTime(t);
}

function setPlaying(playing) {
  viewer.playing = playing && viewer.times.length > 1;
  $('play').textContent = viewer.playing ? 'Pause' : 'Play';
  lastTick = null;
}

let lastTick = null;
const renderTimes = [];

function tick(now) {
  if (viewer.playing) {
    if (lastTick !== null) {
      const times = viewer.times, end = times[times.length - 1];
      let t = viewer.time + (now - lastTick) / 1000 * viewer.speed;
      if (t > end) t = times[0] + (t - end) % Math.max(end - times[0], 1e-9);  // loops
      setTime(t);
    }
    lastTick = now;
  }
  if (needsRender) {
    const began = performance.now();
    updateKeyLight();
    renderer.render(scene, camera);
    viewer.renderMs += 0.1 * (performance.now() - began - viewer.renderMs);
    needsRender = false;
    viewer.renders += 1;
    renderTimes.push(now);
    while (renderTimes.length && renderTimes[0] < now - 1000) renderTimes.shift();
    viewer.fps = renderTimes.length;
  }
  requestAnimationFrame(tick);
}

// ---------------------------------------------------------------------------------------------
// Controls

$('play').addEventListener('click', () => setPlaying(!viewer.playing));
$('scrub').addEventListener('input', (e) => {
  setPlaying(false);
  setTime(viewer.times[Number(e.target.value)]);
});
$('speed').addEventListener('change', (e) => { viewer.speed = Number(e.target.value); });
$('colour').addEventListener('change', (e) => setColourMap(e.target.value));
window.addEventListener('keydown', (e) => {
  // Controls handle their own keys (a focused button clicks on space, the slider moves on arrows).
  if (!viewer.loaded || ['SELECT', 'INPUT', 'BUTTON'].includes(e.target.tagName)) return;
  if (e.key === ' ') { setPlaying(!viewer.playing); e.preventDefault(); }
  if (e.key === 'ArrowRight') { setPlaying(false); setTime(viewer.times[Math.min(viewer.frame + 1, viewer.times.length - 1)]); }
  if (e.key === 'ArrowLeft') { setPlaying(false); setTime(viewer.times[Math.max(viewer.frame - 1, 0)]); }
});

resize();
requestAnimationFrame(tick);
load().catch((e) => fail(`cannot load the run: ${e.message}`));
