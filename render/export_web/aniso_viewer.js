// aniso viewer: the exported material in three.js, sampling the exported KTX2 tables in a
// ShaderMaterial built from the exported shaders/*.glsl, on the exported sample sphere (or the flat
// sample, or the cylinder).
//
// viewer.html?shape=sphere|flat|cylinder&view=x,y,z&light=x,y,z&size=WxH renders exactly the frame of
//   aniso preview MATERIAL --shape sphere|flat|cylinder --view x,y,z --light x,y,z --size WxH
// (orthographic camera along -view framing the object with 10 % margin, the same background and
// fill light, sRGB output), so the two can be compared pixel by pixel. A material with maps is
// drawn per fragment from tables/maps/*.ktx2 by the exported shaders/aniso_maps.glsl. Optional: fill=E,
// background=g or r,g,b (linear), as in `aniso preview`; fps=N times N frames (title says);
// env=1 lights with the export's environment (aniso export --env), as `aniso preview --env`, which
// the orbit viewer does by default where the export has one.
// With no query: an orbit viewer; drag to turn the view, shift+drag to move the light.
import * as THREE from './three.module.js';

const DEFAULTS = { view: [0, -0.8, 0.6], light: [0.7, -0.2, 0.7], fill: 0.15, background: 0.03 };

function vec(s, fallback) {
  if (!s) return fallback;
  const v = s.split(',').map(Number);
  if (v.length !== 3 || v.some((x) => !Number.isFinite(x))) throw new Error('bad vector ' + s);
  return v;
}
const norm = (v) => { const l = Math.hypot(...v); return v.map((x) => x / l); };
const srgb = (v) => { v = Math.min(Math.max(v, 0), 1);
  return v <= 0.0031308 ? 12.92 * v : 1.055 * Math.pow(v, 1 / 2.4) - 0.055; };

// The KTX2 files aniso writes: one level, no supercompression, R32, RGBA16F or RGBA32F
// (io/formats/ktx2.h).
async function loadKtx2(url) {
  const buf = await (await fetch(url)).arrayBuffer();
  const dv = new DataView(buf);
  const id = [0xab, 0x4b, 0x54, 0x58, 0x20, 0x32, 0x30, 0xbb, 0x0d, 0x0a, 0x1a, 0x0a];
  id.forEach((b, i) => { if (dv.getUint8(i) !== b) throw new Error(url + ': not KTX2'); });
  const vkFormat = dv.getUint32(12, true), w = dv.getUint32(20, true), h = dv.getUint32(24, true);
  const layers = dv.getUint32(32, true);  // 0: not an array
  const offset = Number(dv.getBigUint64(80, true)), length = Number(dv.getBigUint64(88, true));
  if (vkFormat === 100) {  // VK_FORMAT_R32_SFLOAT
    const data = new Float32Array(buf.slice(offset, offset + length));
    return { w, h, layers, data, format: THREE.RedFormat, type: THREE.FloatType };
  }
  if (vkFormat === 109) {  // VK_FORMAT_R32G32B32A32_SFLOAT
    const data = new Float32Array(buf.slice(offset, offset + length));
    return { w, h, layers, data, format: THREE.RGBAFormat, type: THREE.FloatType };
  }
  if (vkFormat === 97) {  // VK_FORMAT_R16G16B16A16_SFLOAT
    const data = new Uint16Array(buf.slice(offset, offset + length));
    return { w, h, layers, data, format: THREE.RGBAFormat, type: THREE.HalfFloatType };
  }
  throw new Error(url + ': vkFormat ' + vkFormat + ' is not one aniso writes');
}

// A lookup table (layers = 0) or a 2D array of them as three.js sees it: linear filter, clamped,
// no mipmaps, the first stored row at t = 0 (export.json: row_order). Float tables go to half
// floats where the browser cannot filter float textures.
// With `volume`, a 2D array's layers become a volume's depth (an environment's prefiltered terms:
// levels of <V,T>), repeated round the azimuth.
function tableTexture(t, floatLinear, volume = false) {
  let { data, type } = t;
  if (type === THREE.FloatType && !floatLinear) {
    data = Uint16Array.from(data, (v) => THREE.DataUtils.toHalfFloat(v));
    type = THREE.HalfFloatType;
  }
  const tex = volume ? new THREE.Data3DTexture(data, t.w, t.h, t.layers)
            : t.layers > 0 ? new THREE.DataArrayTexture(data, t.w, t.h, t.layers)
                           : new THREE.DataTexture(data, t.w, t.h);
  tex.format = t.format;
  tex.type = type;
  tex.minFilter = tex.magFilter = THREE.LinearFilter;
  tex.wrapS = volume ? THREE.RepeatWrapping : THREE.ClampToEdgeWrapping;
  tex.wrapT = tex.wrapR = THREE.ClampToEdgeWrapping;
  tex.generateMipmaps = false;
  tex.flipY = false;
  tex.colorSpace = THREE.NoColorSpace;
  tex.needsUpdate = true;
  return tex;
}

// A second fiber direction per vertex (woven cloth): T2 = U cos(psi2) + W sin(psi2), W = N x U, as
// the first (aniso preview's vertex_attributes).
function fiber2(g, U, W, psi2Deg) {
  const c = Math.cos(psi2Deg * Math.PI / 180), s = Math.sin(psi2Deg * Math.PI / 180);
  const T2 = new Float32Array(U.length);
  for (let i = 0; i < U.length; i++) T2[i] = U[i] * c + W[i] * s;
  g.setAttribute('fiber2', new THREE.BufferAttribute(T2, 3));
}

// The sample sphere of gltf/sample.gltf with its texture coordinates and the fiber direction per
// vertex: T = U cos(psi) + (N x U) sin(psi), U the glTF tangent (psi 0 with a map of the fiber
// direction: the shader turns U per fragment).
async function loadSphere(psiDeg, psi2Deg) {
  const gltf = await (await fetch('../gltf/sample.gltf')).json();
  const bin = await (await fetch('../gltf/sample.bin')).arrayBuffer();
  const prim = gltf.meshes[0].primitives[0];
  const acc = (i, Ctor, n) => { const a = gltf.accessors[i], v = gltf.bufferViews[a.bufferView];
    return new Ctor(bin, (v.byteOffset || 0) + (a.byteOffset || 0), a.count * n); };
  const P = acc(prim.attributes.POSITION, Float32Array, 3);
  const N = acc(prim.attributes.NORMAL, Float32Array, 3);
  const U = acc(prim.attributes.TANGENT, Float32Array, 4);
  const UV = acc(prim.attributes.TEXCOORD_0, Float32Array, 2);
  const idx = acc(prim.indices, Uint32Array, 1);
  const c = Math.cos(psiDeg * Math.PI / 180), s = Math.sin(psiDeg * Math.PI / 180);
  const T = new Float32Array(P.length), U3 = new Float32Array(P.length), W3 = new Float32Array(P.length);
  for (let i = 0; i < P.length / 3; i++) {
    const n = [N[3 * i], N[3 * i + 1], N[3 * i + 2]], u = [U[4 * i], U[4 * i + 1], U[4 * i + 2]];
    const w = [n[1] * u[2] - n[2] * u[1], n[2] * u[0] - n[0] * u[2], n[0] * u[1] - n[1] * u[0]];
    for (let k = 0; k < 3; k++) {
      T[3 * i + k] = u[k] * c + w[k] * s;
      U3[3 * i + k] = u[k];
      W3[3 * i + k] = w[k];
    }
  }
  const g = new THREE.BufferGeometry();
  g.setAttribute('position', new THREE.BufferAttribute(P, 3));
  g.setAttribute('normal', new THREE.BufferAttribute(N, 3));
  g.setAttribute('fiber', new THREE.BufferAttribute(T, 3));
  fiber2(g, U3, W3, psi2Deg);
  g.setAttribute('uv', new THREE.BufferAttribute(UV, 2));
  g.setIndex(new THREE.BufferAttribute(idx, 1));
  g.computeBoundingBox();
  return g;
}

// The flat sample of `aniso preview --shape flat`: x = 2u - 1, y = 1 - 2v (uv as the sample lies),
// the normal +z, U along +x; the fiber direction as for the sphere.
function flatGeometry(psiDeg, psi2Deg) {
  const P = new Float32Array([-1, 1, 0, 1, 1, 0, -1, -1, 0, 1, -1, 0]);
  const N = new Float32Array([0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1]);
  const UV = new Float32Array([0, 0, 1, 0, 0, 1, 1, 1]);
  const c = Math.cos(psiDeg * Math.PI / 180), s = Math.sin(psiDeg * Math.PI / 180);
  const T = new Float32Array([c, s, 0, c, s, 0, c, s, 0, c, s, 0]);
  const g = new THREE.BufferGeometry();
  g.setAttribute('position', new THREE.BufferAttribute(P, 3));
  g.setAttribute('normal', new THREE.BufferAttribute(N, 3));
  g.setAttribute('fiber', new THREE.BufferAttribute(T, 3));
  fiber2(g, new Float32Array([1, 0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0]),
         new Float32Array([0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1, 0]), psi2Deg);
  g.setAttribute('uv', new THREE.BufferAttribute(UV, 2));
  g.setIndex([0, 2, 1, 1, 2, 3]);
  g.computeBoundingBox();
  return g;
}

// aniso preview's open cylinder (geometry/mesh.cpp "cylinder": radius 1, height 2, axis z, a
// 128 x 32 grid over u around and v down, U = dP/du along the circles), the fiber turned by psi
// from U toward N x U. Both sides drawn, as the preview draws them.
function cylinderGeometry(psiDeg, psi2Deg) {
  const nu = 128, nv = 32;
  const c = Math.cos(psiDeg * Math.PI / 180), s = Math.sin(psiDeg * Math.PI / 180);
  const P = [], N = [], T = [], UV = [], idx = [], Us = [], Ws = [];
  for (let j = 0; j <= nv; j++)
    for (let i = 0; i <= nu; i++) {
      const u = i / nu, v = j / nv, phi = 2 * Math.PI * u;
      const n = [Math.cos(phi), Math.sin(phi), 0], U = [-Math.sin(phi), Math.cos(phi), 0];
      const w = [n[1] * U[2] - n[2] * U[1], n[2] * U[0] - n[0] * U[2], n[0] * U[1] - n[1] * U[0]];
      P.push(n[0], n[1], 1 - 2 * v);
      N.push(...n);
      T.push(U[0] * c + w[0] * s, U[1] * c + w[1] * s, U[2] * c + w[2] * s);
      Us.push(...U);
      Ws.push(...w);
      UV.push(u, v);
    }
  const id = (i, j) => j * (nu + 1) + i;
  for (let j = 0; j < nv; j++)
    for (let i = 0; i < nu; i++)
      idx.push(id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j), id(i + 1, j + 1), id(i, j + 1));
  const g = new THREE.BufferGeometry();
  g.setAttribute('position', new THREE.BufferAttribute(new Float32Array(P), 3));
  g.setAttribute('normal', new THREE.BufferAttribute(new Float32Array(N), 3));
  g.setAttribute('fiber', new THREE.BufferAttribute(new Float32Array(T), 3));
  fiber2(g, new Float32Array(Us), new Float32Array(Ws), psi2Deg);
  g.setAttribute('uv', new THREE.BufferAttribute(new Float32Array(UV), 2));
  g.setIndex(idx);
  g.computeBoundingBox();
  return g;
}

const VERTEX = `
in vec3 fiber; in vec3 fiber2;
out vec3 vN; out vec3 vT; out vec3 vT2; out vec2 vUV; out vec3 vP;
void main() {
  vN = normal; vT = fiber; vT2 = fiber2; vUV = uv; vP = position;
  gl_Position = projectionMatrix * modelViewMatrix * vec4(position, 1.0);
}`;

// The sphere's mathematical topology (docs/models.md §4, geometry/topology.cpp): meridian fibers
// compressed by 1 / sin(polar angle), the in-cycle rule c' = c / 2^floor(log2 c), s = acos(1/c')
// / 60 deg; the sample sphere is centred at the origin, its poles on z.
const SPHERE_SMATH = `
float sphereSmath(vec3 P) {
  float c = 1.0 / max(length(P.xy) / max(length(P), 1e-12), 1e-6);
  float cp = c / exp2(floor(log2(c)));
  return acos(1.0 / cp) / (3.14159265358979 / 3.0);
}`;

// The fragment shader: the export's own lookup functions (shaders/aniso_lookup.glsl, for the
// fiber model shaders/aniso_fiber.glsl, for a material with maps shaders/aniso_maps.glsl) summed
// over the light and the fill light, sRGB-encoded.
const FRAGMENT_MAIN = `
uniform vec3 kd; uniform vec3 ks; uniform float topologyS; uniform int sphereTopology;
uniform vec3 L0; uniform float E0; uniform vec3 L1; uniform float E1; uniform vec3 V;
in vec3 vN; in vec3 vT; in vec2 vUV; in vec3 vP;
out vec4 fragColor;
${SPHERE_SMATH}
vec3 radiance(vec3 N, vec3 T, vec3 L, float E) {
  float s = sphereTopology == 1 ? sphereSmath(vP) : topologyS;  // with a topology map: s_math
#if defined(ANISO_NPHI) && defined(ANISO_VIEWER_MAPS)
  return anisoFiberRadianceMapped(N, T, vUV, L, V, s, kd, ks, vec3(E));
#elif defined(ANISO_NPHI)
  return anisoFiberRadiance(N, T, L, V, s, kd, ks, vec3(E));
#elif defined(ANISO_VIEWER_MAPS)
  return anisoRadianceMapped(N, T, vUV, L, V, kd, ks, vec3(E));
#else
  return anisoRadiance(N, T, L, V, kd, ks, vec3(E));
#endif
}
float enc(float v) { v = clamp(v, 0.0, 1.0);
  return v <= 0.0031308 ? 12.92 * v : 1.055 * pow(v, 1.0 / 2.4) - 0.055; }
void main() {
  vec3 N = normalize(vN);
  vec3 T = normalize(vT - N * dot(N, vT));
  vec3 c = radiance(N, T, L0, E0) + radiance(N, T, L1, E1);
  fragColor = vec4(enc(c.r), enc(c.g), enc(c.b), 1.0);
}`;

// The material's function files: shaders.glsl[0], for the fiber model shaders.fiber[0], for a
// material with maps shaders.maps[0].
async function materialFunctions(info, fiber) {
  const text = async (f) => (await fetch('../' + f)).text();
  const parts = ['precision highp float;\nprecision highp sampler2DArray;\nprecision highp sampler3D;\n',
                 await text(info.shaders.glsl[0])];
  if (fiber) parts.push(await text(info.shaders.fiber[0]));
  if (info.shaders.maps) parts.push('#define ANISO_VIEWER_MAPS', await text(info.shaders.maps[0]));
  return parts.join('\n') + '\n';
}

async function fragmentShader(info, fiber) {
  return (await materialFunctions(info, fiber)) + FRAGMENT_MAIN;
}

// Light from an environment (an export made with --env): the export's own shaders over its
// prefiltered tables, as aniso preview --env draws them, sRGB-encoded. The line model with one k_d
// and k_s: shaders/aniso_environment.glsl's seven terms (k_d and k_s in them); with maps, D's and
// S's terms apart (aniso_environment_parts.glsl), the fragment's k_d, k_s, n and fiber from the
// maps (aniso_maps.glsl); the fiber model: aniso_environment_fiber.glsl at the fragment's topology.
// A second fiber reads the same tables at T2; the isotropic term its own tables
// (aniso_environment_isotropic.glsl).
const FRAGMENT_ENV_MAIN = `
uniform vec3 V; uniform vec3 kd; uniform vec3 ks; uniform float topologyS; uniform int sphereTopology;
uniform vec3 kdIso; uniform vec3 ksIso; uniform float secondWeight;
in vec3 vN; in vec3 vT; in vec3 vT2; in vec2 vUV; in vec3 vP;
out vec4 fragColor;
${SPHERE_SMATH}
float enc(float v) { v = clamp(v, 0.0, 1.0);
  return v <= 0.0031308 ? 12.92 * v : 1.055 * pow(v, 1.0 / 2.4) - 0.055; }
// The radiance of the lobes at T (and T2) for k_d, k_s and n at the fragment.
vec3 lobes(vec3 N, vec3 T, vec3 T2, vec3 V, float n, vec3 kdv, vec3 ksv) {
#if defined(ANISO_ENV_FIBER) || defined(ANISO_ENV_PARTS)
  vec3 d, s;
#if defined(ANISO_ENV_FIBER)
  float topo = sphereTopology == 1 ? sphereSmath(vP) : topologyS;
#ifdef ANISO_VIEWER_MAPS
  topo = anisoTopologyAt(vUV, topo);
#endif
  anisoFiberEnvironmentParts(N, T, V, topo, n, d, s);
#ifdef ANISO_ENV_SECOND
  vec3 d2, s2;
  anisoFiberEnvironmentParts(N, T2, V, topo, n, d2, s2);
  d = mix(d2, d, secondWeight);
  s = mix(s2, s, secondWeight);
#endif
#else
  anisoEnvironmentParts(N, T, V, n, d, s);
#ifdef ANISO_ENV_SECOND
  vec3 d2, s2;
  anisoEnvironmentParts(N, T2, V, n, d2, s2);
  d = mix(d2, d, secondWeight);
  s = mix(s2, s, secondWeight);
#endif
#endif
  return max(kdv * d + ksv * s, vec3(0.0));
#else
  vec3 r = anisoEnvironmentRadiance(N, T, V);
#ifdef ANISO_ENV_SECOND
  r = mix(anisoEnvironmentRadiance(N, T2, V), r, secondWeight);
#endif
  return r;
#endif
}
void main() {
  vec3 N = normalize(vN);
  vec3 T = normalize(vT - N * dot(N, vT)), T2 = normalize(vT2 - N * dot(N, vT2));
  vec3 kdv = kd, ksv = ks;
  float n = 1.0;
#ifdef ANISO_VIEWER_MAPS
  n = anisoMapsAt(vUV, N, T, kdv, ksv);
#endif
  vec3 r = vec3(0.0);
#ifdef ANISO_ENV_FIBER
  if (dot(N, V) > 0.0) {  // the fibres show nothing from below
#else
  {
#endif
    r = lobes(N, T, T2, V, n, kdv, ksv);
#ifdef ANISO_ENV_ISO
    r += anisoIsotropicEnvironment(N, V, kdIso, ksIso);
#endif
  }
  fragColor = vec4(enc(r.r), enc(r.g), enc(r.b), 1.0);
}`;

// For timing against the plainest lit surface (plain=1): Lambert, no tables.
const FRAGMENT_PLAIN = `
precision highp float;
uniform vec3 kd; uniform vec3 L0;
in vec3 vN; in vec3 vT; in vec2 vUV;
out vec4 fragColor;
void main() { fragColor = vec4(kd * max(dot(normalize(vN), L0), 0.0), 1.0); }`;

export async function start(q) {
  const info = await (await fetch('../export.json')).json();
  const m = info.material;
  const fiber = info.model === 'fiber';
  // The fiber model's topology: one s, a map of s, a topology map, the sphere's mathematical
  // topology (alone or under a topology map: s_math per fragment, else 0, a flat sample's); the
  // viewer has the sample sphere only, so not a torus's.
  const topo = m.topology || {};
  const math = topo.mathematical || 'none';
  if (fiber && typeof topo.s !== 'number' && !topo.s_map && !topo.map && math !== 'sphere')
    throw new Error('the browser viewer draws fiber materials with one topology s, a map of s, a ' +
                    'topology map or the sphere\'s mathematical topology (this one has a ' +
                    math + '\'s: use aniso view)');
  if (fiber && math === 'torus')
    throw new Error('the browser viewer has the sample sphere, not a torus for this material\'s ' +
                    'mathematical topology: use aniso view --shape torus');
  // A material with maps opens on the flat sample, as aniso preview and aniso view open it.
  const hasMaps = ['kd', 'ks', 'fiber', 'n'].some((k) => info.maps[k]);
  const shape = q.get('shape') || (hasMaps ? 'flat' : 'sphere');
  if (shape !== 'sphere' && shape !== 'flat' && shape !== 'cylinder')
    throw new Error('shape ' + shape + ': the viewer has the sample sphere, the flat sample and the ' +
                    'cylinder');
  const [W, H] = (q.get('size') || `${innerWidth}x${innerHeight}`).split('x').map(Number);
  const scripted = q.has('view') || q.has('light') || q.has('size');
  let view = norm(vec(q.get('view'), DEFAULTS.view));
  let light = norm(vec(q.get('light'), DEFAULTS.light));
  const fill = q.has('fill') ? Number(q.get('fill')) : DEFAULTS.fill;
  const bgs = (q.get('background') || String(DEFAULTS.background)).split(',').map(Number);
  const bg = bgs.length === 3 ? bgs : [bgs[0], bgs[0], bgs[0]];

  const renderer = new THREE.WebGLRenderer({ antialias: false, preserveDrawingBuffer: true });
  renderer.setPixelRatio(1);
  renderer.setSize(W, H);
  renderer.outputColorSpace = THREE.LinearSRGBColorSpace;  // the shader encodes sRGB itself
  renderer.setClearColor(new THREE.Color().setRGB(srgb(bg[0]), srgb(bg[1]), srgb(bg[2]),
                                                  THREE.LinearSRGBColorSpace), 1);
  document.body.appendChild(renderer.domElement);
  const floatLinear = renderer.extensions.has('OES_texture_float_linear');

  // The fiber angles at each vertex (0 with a map of the fiber direction: the shader turns U).
  const psi = info.maps.fiber ? 0 : m.fiber_angle_deg || 0;
  const second = m.second_fiber || {};
  const psi2 = typeof second.angle_deg === 'number' ? second.angle_deg : (m.fiber_angle_deg || 0) + 90;
  const [D, S, geometry] = await Promise.all([
    loadKtx2('../' + info.tables.diffuse.ktx2), loadKtx2('../' + info.tables.specular.ktx2),
    shape === 'flat' ? flatGeometry(psi, psi2)
    : shape === 'cylinder' ? cylinderGeometry(psi, psi2) : loadSphere(psi, psi2)]);
  const fiberTables = fiber ? await Promise.all([loadKtx2('../' + info.tables.fiber_G.ktx2),
                                                 loadKtx2('../' + info.tables.fiber_F.ktx2)])
                            : null;
  const uniforms = {
    anisoDiffuse: { value: tableTexture(D, floatLinear) },
    anisoSpecular: { value: tableTexture(S, floatLinear) },
    topologyS: { value: fiber && typeof topo.s === 'number' ? topo.s : 0 },  // else s_math 0
    sphereTopology: { value: fiber && math === 'sphere' ? 1 : 0 },
    kd: { value: new THREE.Vector3(...m.kd) }, ks: { value: new THREE.Vector3(...m.ks) },
    L0: { value: new THREE.Vector3() }, E0: { value: 1 },
    L1: { value: new THREE.Vector3() }, E1: { value: fill },
    V: { value: new THREE.Vector3() },
  };
  // The material's maps (export.json maps: kd, ks, fiber, n) and with a map of n the stack of
  // specular tables, each under the name shaders/aniso_maps.glsl gives it.
  // The topology's maps (a map of s, a topology map) repeat whatever maps.wrap says.
  const mapNames = { kd: 'anisoKdMap', ks: 'anisoKsMap', fiber: 'anisoFiberMap', n: 'anisoNMap',
                     'topology.s_map': 'anisoSMap', 'topology.map': 'anisoTopologyMap',
                     amplitude: 'anisoAmplitudeMap' };
  const wrap = info.maps.wrap === 'repeat' ? THREE.RepeatWrapping : THREE.ClampToEdgeWrapping;
  await Promise.all(Object.entries(mapNames).filter(([key]) => info.maps[key]).map(async ([key, name]) => {
    const tex = tableTexture(await loadKtx2('../' + info.maps[key].ktx2), floatLinear);
    tex.wrapS = tex.wrapT = info.maps[key].wrap === 'repeat' ? THREE.RepeatWrapping : wrap;
    uniforms[name] = { value: tex };
  }));
  if (info.tables.specular_stack)
    uniforms.anisoSpecularStack =
        { value: tableTexture(await loadKtx2('../' + info.tables.specular_stack.ktx2), floatLinear) };
  if (fiber) {
    uniforms.anisoFiberG = { value: tableTexture(fiberTables[0], floatLinear) };
    uniforms.anisoFiberF = { value: tableTexture(fiberTables[1], floatLinear) };
  }
  if (info.tables.fiber_F_stack)  // a fiber material's map of n: F at levels of log n
    uniforms.anisoFiberFStack =
        { value: tableTexture(await loadKtx2('../' + info.tables.fiber_F_stack.ktx2), floatLinear) };
  // An export with an environment lights with it (env=0 asks for the lights; a scripted query, for
  // the lights unless it says env=1).
  let useEnv = info.tables.environment && !q.has('plain') &&
               (q.has('env') ? q.get('env') !== '0' : !scripted);
  if (q.get('env') === '1' && !info.tables.environment)
    throw new Error('env=1: this export has no environment (aniso export --env studio or FILE.exr)');
  // The environment's volumes hold up to 13 x 32 layers (the fiber model's S): WebGL 2 promises
  // 3D textures of 256 only. Where this browser holds fewer than they need, say so: an error when
  // asked for (env=1), else the light.
  if (useEnv) {
    const gl = renderer.getContext(), most = gl.getParameter(gl.MAX_3D_TEXTURE_SIZE);
    const env = info.tables.environment;
    const need = env.model === 'fiber' ? (2 * env.order + 1) * env.layers
               : env.parts ? 7 * env.layers : env.layers;
    if (need > most) {
      const why = `this browser's WebGL holds 3D textures of ${most} layers; the environment ` +
                  `needs ${need} (aniso view draws it)`;
      if (q.get('env') === '1') throw new Error('env=1: ' + why);
      document.getElementById('info').textContent = 'aniso viewer: lit by the light: ' + why;
      useEnv = false;
    }
  }
  let envFragment = '';
  if (useEnv) {
    const env = info.tables.environment;
    const text = async (f) => (await fetch('../' + f)).text();
    const volume = async (f) => tableTexture(await loadKtx2('../' + f), floatLinear, true);
    const defines = [];
    const shaders = [await text(env.shader)];
    if (env.model === 'fiber') {
      defines.push('ANISO_ENV_FIBER');
      uniforms.anisoFibEnvD = { value: await volume(env.tables.D) };
      uniforms.anisoFibEnvS = { value: await volume(env.tables.S) };
      uniforms.anisoFibEnvCoef = { value: await volume(env.tables.coef) };
      uniforms.anisoFibEnvOrder = { value: env.order };
      uniforms.anisoFibEnvLevels = { value: env.layers };
      uniforms.anisoFibEnvPhis = { value: env.phis };
      uniforms.anisoFibEnvSLevels = { value: env.s_levels };
      uniforms.anisoFibEnvNLevels = { value: env.n_levels };
      uniforms.anisoFibEnvLogN0 = { value: env.log_n0 };
      uniforms.anisoFibEnvLogStep = { value: env.log_step };
      uniforms.anisoFibEnvRows = { value: env.size[1] };
    } else if (env.parts) {
      defines.push('ANISO_ENV_PARTS');
      shaders.push(await text(env.parts_shader));
      uniforms.anisoEnvPartD = { value: await volume(env.parts.D) };
      uniforms.anisoEnvPartS = { value: await volume(env.parts.S) };
      uniforms.anisoEnvLevels = { value: env.layers };
      uniforms.anisoEnvPartRows = { value: env.size[1] };
      uniforms.anisoEnvPartNLevels = { value: env.n_levels };
      uniforms.anisoEnvPartLogN0 = { value: env.log_n0 };
      uniforms.anisoEnvPartLogStep = { value: env.log_step };
    } else {
      uniforms.anisoEnv = { value: await Promise.all(env.terms.map(volume)) };
      uniforms.anisoEnvLevels = { value: env.layers };
    }
    const rgb = (x) => (Array.isArray(x) ? x : [x || 0, x || 0, x || 0]);
    if (env.isotropic) {
      defines.push('ANISO_ENV_ISO');
      shaders.push(await text(env.isotropic.shader));
      uniforms.anisoEnvIrr = { value: await volume(env.isotropic.tables.irradiance) };
      uniforms.anisoEnvGloss = { value: await volume(env.isotropic.tables.glossy) };
      uniforms.anisoEnvIsoScale = { value: env.isotropic.scale };
      uniforms.kdIso = { value: new THREE.Vector3(...rgb(m.isotropic.kd)) };
      uniforms.ksIso = { value: new THREE.Vector3(...rgb(m.isotropic.ks)) };
    }
    if (env.second_fiber) {
      defines.push('ANISO_ENV_SECOND');
      uniforms.secondWeight = { value: env.second_fiber.weight };
    }
    envFragment = (await materialFunctions(info, fiber)) +
                  defines.map((d) => '#define ' + d + '\n').join('') + shaders.join('\n') +
                  FRAGMENT_ENV_MAIN;
  }
  const material = new THREE.ShaderMaterial({ glslVersion: THREE.GLSL3, vertexShader: VERTEX,
                                              fragmentShader: q.has('plain') ? FRAGMENT_PLAIN
                                                              : useEnv ? envFragment
                                                                       : await fragmentShader(info, fiber),
                                              uniforms,
                                              side: shape === 'cylinder' ? THREE.DoubleSide
                                                                         : THREE.FrontSide });
  const scene = new THREE.Scene();
  scene.add(new THREE.Mesh(geometry, material));

  // aniso preview's camera: orthographic, along -view, 1.1 x the object's radius, z up.
  const center = geometry.boundingBox.getCenter(new THREE.Vector3());
  const pos = geometry.attributes.position;
  let radius = 0;
  for (let i = 0; i < pos.count; i++)
    radius = Math.max(radius, Math.hypot(pos.getX(i) - center.x, pos.getY(i) - center.y,
                                         pos.getZ(i) - center.z));
  const ext = 1.1 * radius, aspect = W / H;
  const camera = new THREE.OrthographicCamera(-ext * aspect, ext * aspect, ext, -ext, 0.01, 8 * ext);
  camera.up.set(0, 0, 1);

  function frame() {
    camera.position.set(center.x + 4 * ext * view[0], center.y + 4 * ext * view[1],
                        center.z + 4 * ext * view[2]);
    camera.lookAt(center);
    uniforms.V.value.set(...view);
    uniforms.L0.value.set(...light);
    uniforms.L1.value.set(...view);  // the fill light sits at the viewer
    renderer.render(scene, camera);
  }
  frame();
  if (q.has('fps')) {  // timing: N frames, each finished (a one-pixel read waits for the GPU)
    const n = Number(q.get('fps')) || 60, px = new Uint8Array(4), gl = renderer.getContext();
    const t0 = performance.now();
    for (let i = 0; i < n; i++) {
      view = [view[0] * Math.cos(0.01) - view[1] * Math.sin(0.01),
              view[0] * Math.sin(0.01) + view[1] * Math.cos(0.01), view[2]];
      frame();
      gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, px);
    }
    const ms = (performance.now() - t0) / n;
    console.log(`aniso viewer: fps ${(1000 / ms).toFixed(1)} (${ms.toFixed(2)} ms/frame, ${W}x${H}` +
                `${q.has('plain') ? ', plain Lambert shader' : ''})`);
    document.title = `aniso viewer: fps ${(1000 / ms).toFixed(1)} (${ms.toFixed(2)} ms/frame, ` +
                     `${W}x${H}, ${gl.getParameter(gl.RENDERER)})`;
    return;
  }
  if (scripted) {
    document.getElementById('info').classList.add('hidden');
    document.title = 'aniso viewer: rendered';
    return;
  }
  // Orbit: drag turns the view (or, with shift, the light) about z and up/down.
  let last = null;
  const turn = (v, dx, dy) => {
    let az = Math.atan2(v[1], v[0]) - dx * 0.01;
    let el = Math.asin(Math.max(-1, Math.min(1, v[2]))) + dy * 0.01;
    el = Math.max(-1.5, Math.min(1.5, el));
    return [Math.cos(el) * Math.cos(az), Math.cos(el) * Math.sin(az), Math.sin(el)];
  };
  renderer.domElement.addEventListener('pointerdown', (e) => { last = [e.clientX, e.clientY]; });
  addEventListener('pointerup', () => { last = null; });
  addEventListener('pointermove', (e) => {
    if (!last) return;
    const dx = e.clientX - last[0], dy = e.clientY - last[1];
    last = [e.clientX, e.clientY];
    if (e.shiftKey) light = turn(light, dx, dy); else view = turn(view, dx, dy);
    requestAnimationFrame(frame);
  });
}
