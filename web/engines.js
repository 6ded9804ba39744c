// An export's glTF (gltf/sample.gltf) rendered by a real engine's own glTF loader, under the
// camera and lights of `aniso preview --shape sphere` (the export's three.js viewer does the same
// with the exact model): an orthographic camera along -view framing the sphere with 10 % margin,
// z up; a directional light along `light` of irradiance 1 and a fill light at the viewer of
// irradiance `fill`; background `background` (linear); sRGB output, no tone mapping, no
// environment. The glTF's BRDF is fitted to the model's reflectance per unit irradiance
// (render/export/gltf_lobe.h: its Lambert term base colour / pi against k_d D), and both engines
// shade radiance = BRDF * intensity * <N,L>, so a light of irradiance E has intensity E.
//   engines.html?engine=three|babylon|khronos&view=x,y,z&light=x,y,z&size=WxH[&fill=f]
//   [&background=g]
// Served from a root holding export/ (the export folder), three/, babylonjs/, babylonjs-loaders/
// and gltf-viewer/ (web/engines.sh does that). The Khronos glTF Sample Renderer takes its camera
// and lights from the file: the page adds them to a copy (KHR_lights_punctual).
import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { GltfState, GltfView } from '/gltf-viewer/dist/gltf-viewer.module.js';

const vec = (s, d) => (s ? s.split(',').map(Number) : d);
const norm = (v) => { const l = Math.hypot(...v); return v.map((x) => x / l); };
const srgb = (v) => (v <= 0.0031308 ? 12.92 * v : 1.055 * Math.pow(v, 1 / 2.4) - 0.055);

function setup(q) {
  const [W, H] = (q.get('size') || '400x300').split('x').map(Number);
  return { W, H, view: norm(vec(q.get('view'), [0, -0.8, 0.6])),
           light: norm(vec(q.get('light'), [0.7, -0.2, 0.7])),
           fill: q.has('fill') ? Number(q.get('fill')) : 0.15,
           bg: q.has('background') ? Number(q.get('background')) : 0.03 };
}

async function renderThree(s) {
  const renderer = new THREE.WebGLRenderer({ antialias: false, preserveDrawingBuffer: true });
  renderer.setPixelRatio(1);
  renderer.setSize(s.W, s.H);
  renderer.outputColorSpace = THREE.SRGBColorSpace;
  renderer.toneMapping = THREE.NoToneMapping;
  document.body.appendChild(renderer.domElement);
  const scene = new THREE.Scene();
  scene.background = new THREE.Color().setRGB(s.bg, s.bg, s.bg, THREE.LinearSRGBColorSpace);
  const gltf = await new GLTFLoader().loadAsync('/export/gltf/sample.gltf');
  scene.add(gltf.scene);
  const box = new THREE.Box3().setFromObject(gltf.scene);
  const center = box.getCenter(new THREE.Vector3());
  const radius = box.getSize(new THREE.Vector3()).length() / (2 * Math.sqrt(3));  // a sphere
  const ext = 1.1 * radius, aspect = s.W / s.H;
  const camera = new THREE.OrthographicCamera(-ext * aspect, ext * aspect, ext, -ext, 0.01, 8 * ext);
  camera.up.set(0, 0, 1);
  camera.position.set(center.x + 4 * ext * s.view[0], center.y + 4 * ext * s.view[1],
                      center.z + 4 * ext * s.view[2]);
  camera.lookAt(center);
  for (const [dir, e] of [[s.light, 1], [s.view, s.fill]]) {
    const l = new THREE.DirectionalLight(0xffffff, e);
    l.position.set(center.x + dir[0], center.y + dir[1], center.z + dir[2]);
    l.target.position.copy(center);
    scene.add(l, l.target);
  }
  renderer.render(scene, camera);
}

async function renderBabylon(s) {
  const canvas = document.createElement('canvas');
  canvas.width = s.W;
  canvas.height = s.H;
  canvas.style.width = s.W + 'px';
  canvas.style.height = s.H + 'px';
  document.body.appendChild(canvas);
  const engine = new BABYLON.Engine(canvas, false, { preserveDrawingBuffer: true }, false);
  engine.setHardwareScalingLevel(1);
  const scene = new BABYLON.Scene(engine);
  scene.useRightHandedSystem = true;  // glTF's own; the loader then adds no mirroring root
  const g = srgb(s.bg);
  scene.clearColor = new BABYLON.Color4(g, g, g, 1);
  scene.ambientColor = new BABYLON.Color3(0, 0, 0);
  scene.imageProcessingConfiguration.toneMappingEnabled = false;
  scene.imageProcessingConfiguration.exposure = 1;
  scene.imageProcessingConfiguration.contrast = 1;
  const result = await BABYLON.SceneLoader.ImportMeshAsync('', '/export/gltf/', 'sample.gltf', scene);
  let min = new BABYLON.Vector3(Infinity, Infinity, Infinity), max = min.scale(-1);
  for (const m of result.meshes) {
    if (!m.getTotalVertices || m.getTotalVertices() === 0) continue;
    m.computeWorldMatrix(true);
    const b = m.getBoundingInfo().boundingBox;
    min = BABYLON.Vector3.Minimize(min, b.minimumWorld);
    max = BABYLON.Vector3.Maximize(max, b.maximumWorld);
  }
  const center = min.add(max).scale(0.5);
  const radius = max.subtract(min).length() / (2 * Math.sqrt(3));
  const ext = 1.1 * radius, aspect = s.W / s.H;
  const camera = new BABYLON.UniversalCamera('camera',
      new BABYLON.Vector3(center.x + 4 * ext * s.view[0], center.y + 4 * ext * s.view[1],
                          center.z + 4 * ext * s.view[2]), scene);
  camera.upVector = new BABYLON.Vector3(0, 0, 1);
  camera.setTarget(center);
  camera.mode = BABYLON.Camera.ORTHOGRAPHIC_CAMERA;
  camera.orthoLeft = -ext * aspect;
  camera.orthoRight = ext * aspect;
  camera.orthoTop = ext;
  camera.orthoBottom = -ext;
  camera.minZ = 0.01;
  camera.maxZ = 8 * ext;
  for (const [dir, e] of [[s.light, 1], [s.view, s.fill]]) {
    const l = new BABYLON.DirectionalLight('light', new BABYLON.Vector3(-dir[0], -dir[1], -dir[2]), scene);
    l.intensity = e;
    l.specular = new BABYLON.Color3(1, 1, 1);
  }
  await scene.whenReadyAsync();
  scene.render();
}

// The rotation (x, y, z, w) whose local +z is `z` and local +y as close to `up` as it can be.
function frameQuaternion(z, up) {
  const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
  const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                           a[0] * b[1] - a[1] * b[0]];
  let y = up.map((u, i) => u - dot(up, z) * z[i]);
  if (Math.hypot(...y) < 1e-6) y = Math.abs(z[0]) < 0.9 ? [1, 0, 0] : [0, 1, 0];
  y = norm(y.map((u, i) => u - dot(y, z) * z[i]));
  const x = cross(y, z);
  const [m00, m10, m20, m01, m11, m21, m02, m12, m22] = [...x, ...y, ...z];
  const t = m00 + m11 + m22;
  let q;
  if (t > 0) {
    const r = Math.sqrt(1 + t) * 2;
    q = [(m21 - m12) / r, (m02 - m20) / r, (m10 - m01) / r, r / 4];
  } else if (m00 > m11 && m00 > m22) {
    const r = Math.sqrt(1 + m00 - m11 - m22) * 2;
    q = [r / 4, (m01 + m10) / r, (m02 + m20) / r, (m21 - m12) / r];
  } else if (m11 > m22) {
    const r = Math.sqrt(1 + m11 - m00 - m22) * 2;
    q = [(m01 + m10) / r, r / 4, (m12 + m21) / r, (m02 - m20) / r];
  } else {
    const r = Math.sqrt(1 + m22 - m00 - m11) * 2;
    q = [(m02 + m20) / r, (m12 + m21) / r, r / 4, (m10 - m01) / r];
  }
  return q;
}

async function renderKhronos(s) {
  const canvas = document.createElement('canvas');
  canvas.width = s.W;
  canvas.height = s.H;
  document.body.appendChild(canvas);
  const gl = canvas.getContext('webgl2', { preserveDrawingBuffer: true, antialias: false });
  // The renderer binds an environment even with image-based lighting off (a black one, below).
  // Its filtering into cube maps and lookup tables takes 1024-2048 samples a texel (minutes in
  // SwiftShader) for an environment whose intensity is then 0: cut to one sample.
  const names = new WeakMap();
  const getLocation = gl.getUniformLocation.bind(gl), uniform1i = gl.uniform1i.bind(gl);
  gl.getUniformLocation = (program, name) => {
    const at = getLocation(program, name);
    if (at) names.set(at, name);
    return at;
  };
  gl.uniform1i = (at, v) => uniform1i(at, at && names.get(at) === 'u_sampleCount' ? 1 : v);
  // The export's glTF with the preview's camera and lights added, its files from export/gltf/.
  const doc = await (await fetch('/export/gltf/sample.gltf')).json();
  // Its buffers and images handed over as files of the names the document gives them.
  const external = await Promise.all([...(doc.buffers || []), ...(doc.images || [])]
    .filter((b) => b.uri)
    .map(async (b) => [b.uri, new File([await (await fetch('/export/gltf/' + b.uri)).blob()], b.uri)]));
  const pos = doc.accessors[doc.meshes[0].primitives[0].attributes.POSITION];
  const center = pos.min.map((lo, i) => (lo + pos.max[i]) / 2);
  const radius = (pos.max[0] - pos.min[0]) / 2;  // the sample sphere
  const ext = 1.1 * radius, aspect = s.W / s.H;
  doc.cameras = [{ type: 'orthographic', orthographic: { xmag: ext * aspect, ymag: ext,
                                                         znear: 0.01, zfar: 8 * ext } }];
  doc.extensionsUsed = [...(doc.extensionsUsed || []), 'KHR_lights_punctual'];
  doc.extensions = { ...(doc.extensions || {}), KHR_lights_punctual: { lights: [
    { type: 'directional', intensity: 1 }, { type: 'directional', intensity: s.fill }] } };
  const first = doc.nodes.length;
  doc.nodes.push({ camera: 0, rotation: frameQuaternion(s.view, [0, 0, 1]),
                   translation: center.map((c, i) => c + 4 * ext * s.view[i]) },
                 { rotation: frameQuaternion(s.light, [0, 0, 1]),
                   extensions: { KHR_lights_punctual: { light: 0 } } },
                 { rotation: frameQuaternion(s.view, [0, 0, 1]),
                   extensions: { KHR_lights_punctual: { light: 1 } } });
  doc.scenes[doc.scene || 0].nodes.push(first, first + 1, first + 2);
  const file = new File([JSON.stringify(doc)], 'sample.gltf', { type: 'model/gltf+json' });
  const view = new GltfView(gl);
  const state = view.createState();
  const loader = view.createResourceLoader(undefined, undefined, '/gltf-viewer/dist/libs/');
  state.gltf = await loader.loadGltf(['sample.gltf', file], external);
  // The black environment, 16 x 8.
  const header = new TextEncoder().encode('#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 8 +X 16\n');
  const hdr = new Uint8Array(header.length + 16 * 8 * 4);
  hdr.set(header);
  state.environment = await loader.loadEnvironment(hdr.buffer);
  state.sceneIndex = doc.scene || 0;
  state.cameraIndex = 0;
  const p = state.renderingParameters;
  p.useIBL = false;
  p.usePunctual = true;
  p.useDirectionalLightsWithDisabledIBL = false;
  p.renderEnvironmentMap = false;
  p.toneMap = GltfState.ToneMaps.NONE;
  p.exposure = 1;
  const g = srgb(s.bg);
  p.clearColor = [g, g, g, 1];
  view.renderFrame(state, s.W, s.H);
}

export async function render(q) {
  const s = setup(q);
  const engine = q.get('engine') || 'three';
  if (engine === 'three') return renderThree(s);
  if (engine === 'babylon') return renderBabylon(s);
  if (engine === 'khronos') return renderKhronos(s);
  throw new Error('engine ' + engine + ': three, babylon or khronos');
}
