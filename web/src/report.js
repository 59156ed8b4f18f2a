// pipetile's HTML report: the levels of the embedded .glb in three.js, the per-level table, and for
// `pipetile bench` the error against the triangle count of pipetile and its peers (uPlot).
// Bundled by esbuild into the page (CMakeLists.txt); the page's data is in two script elements.

import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import uPlot from 'uplot';
import 'uplot/dist/uPlot.min.css';

const data = JSON.parse(document.getElementById('pipetile-data').textContent);

// What the tests read: the triangles the last frame drew, and the level shown.
window.pipetile = { ready: false, level: 0, trianglesDrawn: 0, error: null };

function glbBytes() {
  const text = document.getElementById('pipetile-glb').textContent.trim();
  const binary = atob(text);
  const bytes = new Uint8Array(binary.length);
  for (let i = 0; i < binary.length; ++i) bytes[i] = binary.charCodeAt(i);
  return bytes.buffer;
}

// The colours of `pipetile validate --error-colors` (src/validate.cpp, errorColors): blue at 0,
// through green and yellow, to red at `redAt` and beyond.
const kStops = [[0.1, 0.2, 1.0], [0.1, 0.8, 0.2], [1.0, 0.9, 0.1], [1.0, 0.1, 0.1]];
function errorColors(errors, redAt) {
  const colors = new Float32Array(3 * errors.count);
  for (let v = 0; v < errors.count; ++v) {
    const x = Math.min(Math.max(redAt > 0 ? errors.getX(v) / redAt : 1, 0), 1) * 3;
    const i = Math.min(2, Math.floor(x));
    for (let c = 0; c < 3; ++c) {
      const linear = kStops[i][c] + (x - i) * (kStops[i + 1][c] - kStops[i][c]);
      colors[3 * v + c] = Math.pow(linear, 2.2); // the stops are sRGB; the renderer works in linear
    }
  }
  return new THREE.BufferAttribute(colors, 3);
}

const fmt = (v, digits = 3) => (v === undefined || v === null ? '—' : Number(v).toFixed(digits));
const yesNo = (b) => (b === undefined ? '—' : b ? 'yes' : 'NO');

function topologyText(level) {
  const v = level.validation;
  if (v) return `${v.closed && v.manifold && v.oriented ? 'closed manifold' : [v.closed ? '' : 'open', v.manifold ? '' : 'non-manifold', v.oriented ? '' : 'misoriented'].filter(Boolean).join(', ')}, χ ${v.euler}, ${v.components} part${v.components === 1 ? '' : 's'}`;
  if (level.euler !== undefined) return `χ ${level.euler}, ${level.components} part${level.components === 1 ? '' : 's'}`;
  return '—';
}

function fillTable(levels) {
  const table = document.getElementById('levels');
  table.innerHTML = '<tr><th>level</th><th>rays</th><th>vertices</th><th>triangles</th><th>seconds</th>' +
    '<th>Hausdorff (voxels)</th><th>RMS (voxels)</th><th>smallest angle</th><th>topology</th></tr>';
  levels.forEach((level, k) => {
    const v = level.validation || {};
    const row = table.insertRow();
    row.dataset.level = k;
    const cells = [level.name ?? `L${level.level}`, level.rays ?? '—', level.vertices, level.triangles, fmt(level.seconds, 4),
      fmt(v.hausdorff_voxels), fmt(v.rms_voxels), v.smallest_angle === undefined ? '—' : `${fmt(v.smallest_angle, 1)}°`,
      topologyText(level)];
    cells.forEach((text, i) => {
      const cell = row.insertCell();
      cell.textContent = text;
      if (i === 0 || i === cells.length - 1) cell.className = 'text';
    });
  });
}

// Hausdorff and RMS against triangles, one pair of series per kind of method (bench peers).
function groupOf(method) {
  if (method.startsWith('volumeToMesh')) return 'volumeToMesh adaptive';
  if (method.startsWith('uniform + meshopt')) return 'uniform + meshopt_simplify';
  if (method.includes('every slice')) return 'pipetile, every slice';
  return 'pipetile levels';
}

function drawPlot(peers) {
  // Distances are measured to volumeToMesh's uniform isosurface, so that peer is the reference
  // itself: at distance 0 up to rounding, it has no place on logarithmic axes.
  const isReference = (p) => p.method === 'volumeToMesh uniform';
  const reference = peers.filter(isReference);
  document.getElementById('plot-note').textContent = reference.length
    ? `Not plotted: volumeToMesh uniform (${reference[0].triangles} triangles), the reference the distances are measured to.` : '';
  const groups = new Map();
  for (const p of peers.filter((p) => !isReference(p))) {
    const g = groupOf(p.method);
    if (!groups.has(g)) groups.set(g, []);
    groups.get(g).push(p);
  }
  const palette = ['#d62728', '#1f77b4', '#2ca02c', '#9467bd'];
  const tables = [], series = [{ label: 'triangles' }];
  [...groups.entries()].forEach(([name, rows], i) => {
    rows.sort((a, b) => a.triangles - b.triangles);
    tables.push([rows.map((r) => r.triangles), rows.map((r) => r.hausdorff_voxels), rows.map((r) => r.rms_voxels)]);
    const stroke = palette[i % palette.length];
    series.push({ label: `${name}: Hausdorff`, stroke, width: 2, spanGaps: true, points: { show: true, size: 7 } });
    series.push({ label: `${name}: RMS`, stroke, width: 1, dash: [6, 4], spanGaps: true, points: { show: true, size: 5 } });
  });
  document.getElementById('plot-section').hidden = false;
  const opts = {
    width: 900, height: 420, series, legend: { live: false },
    scales: { x: { time: false, distr: 3 }, y: { distr: 3 } },
    axes: [{ label: 'triangles' }, { label: 'distance to the isosurface (voxels)' }],
  };
  window.pipetile.plot = new uPlot(opts, uPlot.join(tables), document.getElementById('plot'));
}

function startViewer(meshes) {
  const view = document.getElementById('view');
  const renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
  renderer.setPixelRatio(window.devicePixelRatio);
  renderer.setSize(view.clientWidth, view.clientHeight);
  view.prepend(renderer.domElement);
  const scene = new THREE.Scene();
  scene.background = new THREE.Color(0xf4f5f7);
  scene.add(new THREE.HemisphereLight(0xffffff, 0x555566, 2.0));
  const sun = new THREE.DirectionalLight(0xffffff, 1.5);
  scene.add(sun);

  // Every level nests in the finest, so one box frames them all: its bounding sphere fits the
  // narrower of the view's two angles, from whichever side the camera looks.
  const box = new THREE.Box3().setFromObject(meshes[meshes.length - 1]);
  const centre = box.getCenter(new THREE.Vector3());
  const radius = box.getSize(new THREE.Vector3()).length() / 2 || 1;
  const fov = 40, aspect = view.clientWidth / view.clientHeight;
  const halfAngle = Math.min(THREE.MathUtils.degToRad(fov / 2), Math.atan(Math.tan(THREE.MathUtils.degToRad(fov / 2)) * aspect));
  const distance = (1.05 * radius) / Math.sin(halfAngle);
  const camera = new THREE.PerspectiveCamera(fov, aspect, distance / 100, distance * 100);
  camera.position.copy(centre).add(new THREE.Vector3(0.9, 0.6, 1.4).normalize().multiplyScalar(distance));
  const controls = new OrbitControls(camera, renderer.domElement);
  controls.target.copy(centre);
  controls.update(); // the camera turns to the target (it looked at the origin)

  const hasError = meshes[0].geometry.getAttribute('_error') !== undefined;
  const redAt = data.glb.voxel_metres;
  const colored = new THREE.MeshStandardMaterial({ vertexColors: true, roughness: 0.6, side: THREE.DoubleSide });
  const plain = new THREE.MeshStandardMaterial({ color: 0xc8a27a, roughness: 0.6, side: THREE.DoubleSide });
  for (const mesh of meshes) {
    if (hasError) mesh.geometry.setAttribute('color', errorColors(mesh.geometry.getAttribute('_error'), redAt));
    if (!mesh.geometry.getAttribute('normal')) mesh.geometry.computeVertexNormals();
  }
  const colorsBox = document.getElementById('colors');
  if (hasError) {
    document.getElementById('legend').hidden = false;
    document.getElementById('colors-label').hidden = false;
    document.getElementById('legend-max').textContent = `≥ 1 voxel (${redAt.toPrecision(3)} m)`;
  }

  const slider = document.getElementById('level');
  slider.max = meshes.length - 1;
  slider.value = meshes.length - 1;
  let shown = null;
  const render = () => {
    sun.position.copy(camera.position);
    renderer.render(scene, camera);
    window.pipetile.trianglesDrawn = renderer.info.render.triangles;
    renderer.domElement.dataset.triangles = renderer.info.render.triangles;
    document.getElementById('drawn').textContent = `${renderer.info.render.triangles} triangles drawn`;
  };
  const show = () => {
    const k = Number(slider.value);
    if (shown) scene.remove(shown);
    shown = meshes[k];
    const material = hasError && colorsBox.checked ? colored : plain;
    material.wireframe = document.getElementById('wireframe').checked;
    shown.material = material;
    scene.add(shown);
    window.pipetile.level = k;
    document.getElementById('level-name').textContent = data.levels[k]?.name ?? `L${k}`;
    document.querySelectorAll('#levels tr').forEach((tr) => tr.classList.toggle('current', tr.dataset.level === String(k)));
    render();
  };
  slider.addEventListener('input', show);
  document.getElementById('wireframe').addEventListener('change', show);
  colorsBox.addEventListener('change', show);
  controls.addEventListener('change', render);
  window.addEventListener('resize', () => {
    camera.aspect = view.clientWidth / view.clientHeight;
    camera.updateProjectionMatrix();
    renderer.setSize(view.clientWidth, view.clientHeight);
    render();
  });
  show();
}

async function main() {
  document.getElementById('title').textContent = data.title;
  document.getElementById('subtitle').textContent = data.subtitle;
  fillTable(data.levels);
  if (data.peers) drawPlot(data.peers);
  const loader = new GLTFLoader();
  const gltf = await loader.parseAsync(glbBytes(), '');
  // One mesh per level, coarse first (the file's meshes are in level order; MSFT_lod is for viewers).
  const meshes = [];
  for (let k = 0; k < gltf.parser.json.meshes.length; ++k) {
    const group = await gltf.parser.getDependency('mesh', k);
    const mesh = group.isMesh ? group : group.children[0];
    const node = gltf.parser.json.nodes[k];
    if (node.translation) mesh.position.fromArray(node.translation);
    meshes.push(mesh);
  }
  startViewer(meshes);
  window.pipetile.ready = true;
}

main().catch((e) => {
  window.pipetile.error = String(e);
  console.error(e);
});
