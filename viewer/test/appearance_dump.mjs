#!/usr/bin/env node
// The viewer's colour maps, strain field and strain scale (viewer/src/appearance.js,
// viewer/src/strain.js, with src/render/appearance.json) on the inputs of a request file, for
// tests/render/test_appearance.cpp, which compares them with weft's own (src/render/appearance.hpp).
//
//     node viewer/test/appearance_dump.mjs REQUEST.json
//
// REQUEST: {"fractions": [...], "signed_fractions": [...], "positions": [x, y, z, ...],
// "texcoords": [u, v, ...], "indices": [i, j, k, ...], "uv_scale": S, "values": [...],
// "generated_values": N}. Prints JSON: {"sequential": [[r, g, b], ...], "diverging": [...],
// "cloth_front", "cloth_back", "collider": [r, g, b], "strain": [...], "scale": x,
// "generated_scale": x}, colours in linear RGB. The N generated values are
// ((k * 7919) % 10007) / 10007 - 0.5 for k = 0 .. N - 1 (exact in both languages).
import {readFileSync} from 'node:fs';
import {dirname, join} from 'node:path';
import {fileURLToPath} from 'node:url';
import {makeAppearance} from '../src/appearance.js';
import {strainField} from '../src/strain.js';

const here = dirname(fileURLToPath(import.meta.url));
const table = JSON.parse(readFileSync(join(here, '..', '..', 'src', 'render', 'appearance.json'), 'utf8'));
const request = JSON.parse(readFileSync(process.argv[2], 'utf8'));
const look = makeAppearance(table);
const strain = new Float64Array(request.positions.length / 3);
strainField(request.positions, request.texcoords, request.indices, request.uv_scale, strain);
const generated = [];
for (let k = 0; k < request.generated_values; ++k) generated.push(((k * 7919) % 10007) / 10007 - 0.5);
console.log(JSON.stringify({
  sequential: request.fractions.map((f) => look.sequential(f, [0, 0, 0])),
  diverging: request.signed_fractions.map((f) => look.diverging(f, [0, 0, 0])),
  cloth_front: look.clothFront,
  cloth_back: look.clothBack,
  collider: look.collider,
  strain: Array.from(strain),
  scale: look.strainScale(request.values),
  generated_scale: look.strainScale(generated),
}));
