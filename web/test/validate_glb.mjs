// The .glb of `pipetile mesh -o X.glb --validate` through the Khronos glTF validator: no errors.
// MSFT_lod is reported as an unsupported extension (an info), which is fine: it is only used.
// usage: node validate_glb.mjs PIPETILE
import { execFileSync } from 'node:child_process';
import { mkdtempSync, readFileSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import validator from 'gltf-validator';

const [pipetile] = process.argv.slice(2);
const folder = mkdtempSync(join(tmpdir(), 'pipetile-glb-'));
const glb = join(folder, 'vessel.glb');
execFileSync(pipetile, ['mesh', '-o', glb, '--validate', '--units', 'mm'], { stdio: ['ignore', 'ignore', 'inherit'] });
const report = await validator.validateBytes(new Uint8Array(readFileSync(glb)));
rmSync(folder, { recursive: true, force: true });
for (const m of report.issues.messages) console.log(`severity ${m.severity} ${m.code} ${m.pointer ?? ''}: ${m.message}`);
const { numErrors, numWarnings } = report.issues;
const info = report.info;
console.log(`${glb}: ${numErrors} errors, ${numWarnings} warnings; ${info.drawCallCount} draw calls, ` +
            `${info.totalVertexCount} vertices, ${info.totalTriangleCount} triangles, extensions used ${info.extensionsUsed}`);
let failed = numErrors !== 0;
// The extension is used, never required, so viewers without it show the finest level.
if (!(info.extensionsUsed ?? []).includes('MSFT_lod') || (info.extensionsRequired ?? []).length !== 0) {
  console.log('MSFT_lod must be in extensionsUsed and nothing in extensionsRequired');
  failed = true;
}
process.exit(failed ? 1 : 0);
