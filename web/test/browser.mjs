// The HTML reports of `pipetile mesh --validate --html`, `pipetile validate --html` and `pipetile
// bench --html`, opened from disk in Debian's Chromium (headless, WebGL through SwiftShader): the
// view draws, the level slider changes what is drawn to exactly that level's triangles, bench's
// plot draws a Hausdorff and an RMS series per kind of method, no console error, no request.
// usage: node browser.mjs PIPETILE [SCREENSHOT.png]; with PIPETILE_REAL_DATA (the shared real data's
// folder) the vmtk aorta's report too.
import { execFileSync } from 'node:child_process';
import { mkdtempSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import { pathToFileURL } from 'node:url';
import { chromium } from 'playwright-core';

const [pipetile, screenshot] = process.argv.slice(2);
const folder = mkdtempSync(join(tmpdir(), 'pipetile-browser-'));
const run = (...args) => execFileSync(pipetile, args, { stdio: ['ignore', 'ignore', 'inherit'] });
const failures = [];
const check = (ok, what) => {
  console.log(`${ok ? 'ok  ' : 'FAIL'} ${what}`);
  if (!ok) failures.push(what);
};

// The reports: every level of the phantom, validated; and one mesh file validated on its own.
const meshPage = join(folder, 'mesh.html'), validatePage = join(folder, 'validate.html');
const benchPage = join(folder, 'bench.html');
run('mesh', '-o', join(folder, 'phantom.ply'), '--validate', '--html', meshPage);
run('sample', 'phantom', '-o', join(folder, 'phantom.vdb'));
run('validate', join(folder, 'phantom.vdb'), join(folder, 'phantom_L1.ply'), '--html', validatePage);
run('sample', 'straight', '-o', join(folder, 'straight.vdb'));
run('bench', join(folder, 'straight.vdb'), '--repeat', '1', '--html', benchPage);
// A tall, thin object: the aorta and its iliac arteries (its top was cut off the view).
const realData = process.env.PIPETILE_REAL_DATA;
const aortaPage = join(folder, 'aorta.html');
if (realData) run('mesh', join(realData, 'vmtk_aorta_ls.vdb'), '-o', join(folder, 'aorta.glb'), '--html', aortaPage);

const browser = await chromium.launch({
  executablePath: process.env.PIPETILE_CHROMIUM || '/usr/bin/chromium',
  args: ['--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--no-sandbox'],
});

// Share of the view's pixels that differ from the background: 0 for a blank view. With `border`,
// of the pixels on its outermost two rows and columns only: 0 when the whole object lies inside.
const drawnShare = (border = false) => {
  const canvas = document.querySelector('#view canvas');
  const copy = document.createElement('canvas');
  copy.width = canvas.width, copy.height = canvas.height;
  const context = copy.getContext('2d');
  context.drawImage(canvas, 0, 0);
  const pixels = context.getImageData(0, 0, copy.width, copy.height).data;
  let drawn = 0, counted = 0;
  for (let y = 0; y < copy.height; ++y)
    for (let x = 0; x < copy.width; ++x) {
      if (border && x > 1 && y > 1 && x < copy.width - 2 && y < copy.height - 2) continue;
      const i = 4 * (y * copy.width + x);
      ++counted;
      if (Math.abs(pixels[i] - 0xf4) + Math.abs(pixels[i + 1] - 0xf5) + Math.abs(pixels[i + 2] - 0xf7) > 24) ++drawn;
    }
  return drawn / counted;
};

async function checkPage(file, shot) {
  const page = await browser.newPage({ viewport: { width: 1100, height: 1000 } });
  const url = pathToFileURL(file).href;
  const requests = [], errors = [];
  page.on('request', (r) => { if (r.url() !== url) requests.push(r.url()); });
  page.on('console', (m) => { if (m.type() === 'error') errors.push(m.text()); });
  page.on('pageerror', (e) => errors.push(String(e)));
  await page.goto(url);
  await page.waitForFunction(() => window.pipetile && (window.pipetile.ready || window.pipetile.error), null,
                             { timeout: 20000 });
  const name = file.split('/').pop();
  check((await page.evaluate(() => window.pipetile.error)) === null, `${name}: the viewer started`);
  const levels = await page.evaluate(() => JSON.parse(document.getElementById('pipetile-data').textContent).levels);
  const share = await page.evaluate(drawnShare);
  check(share > 0.02, `${name}: the view is not blank (${(100 * share).toFixed(1)}% of its pixels drawn)`);
  // The whole object is framed: nothing drawn touches the view's edges (the aorta's top was cut off).
  const edge = await page.evaluate(drawnShare, true);
  check(edge === 0, `${name}: the object lies inside the view (${(100 * edge).toFixed(1)}% of the edge drawn)`);
  // One mesh per frame: the triangles drawn are exactly the level's.
  const finest = levels.length - 1;
  let drawn = await page.evaluate(() => window.pipetile.trianglesDrawn);
  check(drawn === levels[finest].triangles, `${name}: the finest level draws its ${levels[finest].triangles} triangles (drew ${drawn})`);
  if (finest > 0) {
    await page.locator('#level').fill('0');
    drawn = await page.evaluate(() => window.pipetile.trianglesDrawn);
    check(drawn === levels[0].triangles && drawn !== levels[finest].triangles,
          `${name}: level 0 draws its ${levels[0].triangles} triangles (drew ${drawn})`);
    await page.locator('#level').fill(String(finest));
  }
  const legend = await page.locator('#legend').isVisible();
  check(legend === (levels[0].validation !== undefined), `${name}: the error legend shows when validated`);
  await page.locator('#wireframe').check();
  check((await page.evaluate(drawnShare)) > 0.005, `${name}: the wireframe draws`);
  await page.locator('#wireframe').uncheck();
  const peers = await page.evaluate(() => JSON.parse(document.getElementById('pipetile-data').textContent).peers);
  if (peers) {
    // volumeToMesh adaptive, uniform + meshopt_simplify, pipetile's levels, pipetile on every slice:
    // two series each (volumeToMesh uniform is the reference, at distance 0).
    const series = await page.evaluate(() => window.pipetile.plot.series.length);
    check(series === 1 + 2 * 4, `${name}: the plot has x and 8 series (has ${series})`);
    // uPlot's canvas is transparent where it draws nothing.
    const inked = await page.evaluate(() => {
      const c = document.querySelector('#plot canvas');
      const pixels = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
      let n = 0;
      for (let i = 3; i < pixels.length; i += 4) if (pixels[i] > 0) ++n;
      return n / (pixels.length / 4);
    });
    check(inked > 0.002, `${name}: the plot draws (${(100 * inked).toFixed(2)}% of its pixels)`);
  }
  if (shot) await page.screenshot({ path: shot, fullPage: true });
  check(errors.length === 0, `${name}: no console error${errors.length ? ': ' + errors.join(' | ') : ''}`);
  check(requests.length === 0, `${name}: no request${requests.length ? ': ' + requests.join(' ') : ''}`);
  await page.close();
}

try {
  await checkPage(meshPage, screenshot);
  await checkPage(validatePage);
  await checkPage(benchPage);
  if (realData) await checkPage(aortaPage);
  else console.log('skip aorta.html: PIPETILE_REAL_DATA is not set');
} finally {
  await browser.close();
  rmSync(folder, { recursive: true, force: true });
}
process.exit(failures.length ? 1 : 0);
