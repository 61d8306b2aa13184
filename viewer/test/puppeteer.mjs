// puppeteer-core for the viewer's test and measurements: from $WEFT_VIEWER_NPM_DIR/node_modules
// (the build installs viewer/package-lock.json in BUILD/viewer-npm), else from viewer/node_modules.
import {createRequire} from 'node:module';
import {join, resolve} from 'node:path';

export async function loadPuppeteer() {
  const npmDir = process.env.WEFT_VIEWER_NPM_DIR;
  if (npmDir) return createRequire(join(resolve(npmDir), 'package.json'))('puppeteer-core');
  return (await import('puppeteer-core')).default;
}
