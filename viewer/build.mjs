// Bundles the viewer's page into OUT_DIR (the build folder's viewer/): index.html, viewer.css
// and viewer.js, which holds three.js and the page's code, so the page needs no network. The
// npm packages come from NPM_DIR/node_modules (where `npm ci` installed viewer/package-lock.json;
// the build uses BUILD/viewer-npm), by default viewer/node_modules.
//
//     node build.mjs OUT_DIR [NPM_DIR]
import {copyFileSync, mkdirSync} from 'node:fs';
import {createRequire} from 'node:module';
import {dirname, join, resolve} from 'node:path';
import {fileURLToPath} from 'node:url';

const here = dirname(fileURLToPath(import.meta.url));
const [out, npmDir = here] = process.argv.slice(2);
if (!out) {
  console.error('usage: node build.mjs OUT_DIR [NPM_DIR]');
  process.exit(2);
}
const modules = join(resolve(npmDir), 'node_modules');
const esbuild = createRequire(join(resolve(npmDir), 'package.json'))('esbuild');
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
  nodePaths: [modules],
});
for (const name of ['index.html', 'viewer.css']) copyFileSync(join(here, 'src', name), join(out, name));
