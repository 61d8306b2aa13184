// Bundles the viewer's page into OUT_DIR (the build folder's viewer/): index.html, viewer.css
// and viewer.js, which holds three.js and the page's code, so the page needs no network.
//
//     node build.mjs OUT_DIR
import * as esbuild from 'esbuild';
import {copyFileSync, mkdirSync} from 'node:fs';
import {dirname, join} from 'node:path';
import {fileURLToPath} from 'node:url';

const here = dirname(fileURLToPath(import.meta.url));
const out = process.argv[2];
if (!out) {
  console.error('usage: node build.mjs OUT_DIR');
  process.exit(2);
}
mkdirSync(out, {recursive: true});
await esbuild.build({
  entryPoints: [join(here, 'src', 'main.js')],
  bundle: true,
  minify: true,
  format: 'esm',
  target: ['es2020'],
  outfile: join(out, 'viewer.js'),
  legalComments: 'eof',
  logLevel: 'warning',
});
for (const name of ['index.html', 'viewer.css']) copyFileSync(join(here, 'src', name), join(out, name));
