// Loads a .glb with real clients and prints what they saw, as JSON on stdout:
// - the Khronos glTF validator (gltf-validator): error and warning counts, and the messages;
// - three.js: GLTFLoader with a DRACOLoader, triangles and bounding box of the loaded scene.
// three's DRACOLoader decodes in Web Workers, which Node lacks; NodeDracoLoader keeps its
// interface and decodes in this thread with the same Draco decoder module (draco3d).
// - draco3d alone (or the plain accessors): the primitives welded into one mesh by the rules of
//   isoslab's _ISOSLAB_SEAM keys (encode/draco_writers.h), written here from that description, not
//   from isoslab's reader; then its vertices, triangles, boundary and non-manifold edges and Euler
//   characteristic (V - E + F), as `welded`.
//
//   node gltf_check.mjs FILE.glb
import { readFileSync } from 'node:fs';
import validator from 'gltf-validator';
import draco3d from 'draco3d';
import { Box3, BufferAttribute, BufferGeometry } from 'three';
import { GLTFLoader } from 'three/examples/jsm/loaders/GLTFLoader.js';
import { DRACOLoader } from 'three/examples/jsm/loaders/DRACOLoader.js';

const path = process.argv[2];
const bytes = new Uint8Array(readFileSync(path));
const report = await validator.validateBytes(bytes, { maxIssues: 50 });

const decoderModule = await draco3d.createDecoderModule({});

class NodeDracoLoader extends DRACOLoader {
  // No decoder files to fetch: the module is already here.
  preload() {
    return this;
  }
  _initDecoder() {
    return Promise.resolve();
  }

  decodeGeometry(buffer, taskConfig) {
    const m = decoderModule;
    const decoder = new m.Decoder();
    const mesh = new m.Mesh();
    const array = new Int8Array(buffer);
    const status = decoder.DecodeArrayToMesh(array, array.byteLength, mesh);
    if (!status.ok() || mesh.ptr === 0) return Promise.reject(new Error('Draco decoding failed: ' + status.error_msg()));
    const geometry = new BufferGeometry();
    const indexCount = mesh.num_faces() * 3;
    let ptr = m._malloc(indexCount * 4);
    decoder.GetTrianglesUInt32Array(mesh, indexCount * 4, ptr);
    geometry.setIndex(new BufferAttribute(new Uint32Array(m.HEAPU32.buffer, ptr, indexCount).slice(), 1));
    m._free(ptr);
    for (const [name, id] of Object.entries(taskConfig.attributeIDs)) {
      const attribute = decoder.GetAttributeByUniqueId(mesh, id);
      const components = attribute.num_components();
      const count = mesh.num_points() * components;
      ptr = m._malloc(count * 4);
      decoder.GetAttributeDataArrayForAllPoints(mesh, attribute, m.DT_FLOAT32, count * 4, ptr);
      geometry.setAttribute(name, new BufferAttribute(new Float32Array(m.HEAPF32.buffer, ptr, count).slice(), components));
      m._free(ptr);
    }
    m.destroy(mesh);
    m.destroy(decoder);
    return Promise.resolve(geometry);
  }
}

// The glTF JSON and binary chunks of a .glb.
function glbChunks(data) {
  const view = new DataView(data.buffer, data.byteOffset, data.byteLength);
  let json = null;
  let bin = null;
  for (let at = 12; at + 8 <= data.byteLength;) {
    const length = view.getUint32(at, true);
    const type = view.getUint32(at + 4, true);
    const body = data.subarray(at + 8, at + 8 + length);
    if (type === 0x4e4f534a) json = JSON.parse(new TextDecoder().decode(body));
    if (type === 0x004e4942) bin = body;
    at += 8 + length;
  }
  return { json, bin };
}

// One primitive's positions (flat xyz), seam keys (one 32-bit value a vertex, or null) and
// triangle indices, decoded by draco3d or read from the plain accessors.
function primitiveData(gltf, bin, primitive) {
  const viewBytes = (index) => {
    const v = gltf.bufferViews[index];
    return bin.subarray(v.byteOffset ?? 0, (v.byteOffset ?? 0) + v.byteLength);
  };
  const draco = primitive.extensions?.KHR_draco_mesh_compression;
  if (draco) {
    const m = decoderModule;
    const decoder = new m.Decoder();
    const mesh = new m.Mesh();
    const bytes = new Int8Array(viewBytes(draco.bufferView));
    const status = decoder.DecodeArrayToMesh(bytes, bytes.byteLength, mesh);
    if (!status.ok()) throw new Error('Draco decoding failed: ' + status.error_msg());
    const points = mesh.num_points();
    const read = (id, components) => {
      const attribute = decoder.GetAttributeByUniqueId(mesh, id);
      const out = new m.DracoFloat32Array();
      decoder.GetAttributeFloatForAllPoints(mesh, attribute, out);
      const values = new Float64Array(points * components);
      for (let k = 0; k < values.length; ++k) values[k] = out.GetValue(k);
      m.destroy(out);
      return values;
    };
    const positions = read(draco.attributes.POSITION, 3);
    let keys = null;
    if (draco.attributes._ISOSLAB_SEAM !== undefined) {
      const halves = read(draco.attributes._ISOSLAB_SEAM, 2);
      keys = new Array(points);
      for (let v = 0; v < points; ++v) keys[v] = halves[2 * v] + 65536 * halves[2 * v + 1];
    }
    const faces = new m.DracoUInt32Array();
    const indices = new Uint32Array(mesh.num_faces() * 3);
    for (let f = 0; f < mesh.num_faces(); ++f) {
      decoder.GetFaceFromMesh(mesh, f, faces);
      for (let c = 0; c < 3; ++c) indices[3 * f + c] = faces.GetValue(c);
    }
    m.destroy(faces);
    m.destroy(mesh);
    m.destroy(decoder);
    return { positions, keys, indices };
  }
  const accessor = (index) => {
    const a = gltf.accessors[index];
    const v = gltf.bufferViews[a.bufferView];
    const components = { SCALAR: 1, VEC2: 2, VEC3: 3 }[a.type];
    const size = { 5121: 1, 5123: 2, 5125: 4, 5126: 4 }[a.componentType];
    const stride = v.byteStride ?? components * size;
    const bytes = viewBytes(a.bufferView);
    const dv = new DataView(bytes.buffer, bytes.byteOffset + (a.byteOffset ?? 0));
    const out = new Float64Array(a.count * components);
    for (let i = 0; i < a.count; ++i) {
      for (let c = 0; c < components; ++c) {
        const at = i * stride + c * size;
        out[i * components + c] = a.componentType === 5126 ? dv.getFloat32(at, true)
          : size === 4 ? dv.getUint32(at, true) : size === 2 ? dv.getUint16(at, true) : dv.getUint8(at);
      }
    }
    return out;
  };
  const positions = accessor(primitive.attributes.POSITION);
  let keys = null;
  if (primitive.attributes._ISOSLAB_SEAM !== undefined) {
    const halves = accessor(primitive.attributes._ISOSLAB_SEAM);
    keys = Array.from({ length: halves.length / 2 }, (_, v) => halves[2 * v] + 65536 * halves[2 * v + 1]);
  }
  return { positions, keys, indices: Uint32Array.from(accessor(primitive.indices)) };
}

// Welds the primitives in order, as encode/draco_writers.h describes the keys: a key k >= 2 of the
// seam's parity ((k - 2) % 2 == (p - 1) % 2 for primitive p) is the previous primitive's vertex
// with that key; an unmarked vertex (0) is the previous primitive's unmarked vertex at the same
// position when each primitive has exactly one there; 1 is never welded by position; points of
// one primitive that carry one key >= 2 are one vertex.
function weld(gltf, bin, primitives = gltf.meshes.flatMap((m) => m.primitives)) {
  let vertices = 0;
  const triangles = [];
  let previousKeys = new Map();
  let previousUnmarked = new Map();
  primitives.forEach((primitive, p) => {
    const { positions, keys, indices } = primitiveData(gltf, bin, primitive);
    const count = positions.length / 3;
    const at = (v) => `${positions[3 * v]},${positions[3 * v + 1]},${positions[3 * v + 2]}`;
    const mark = (v) => (keys ? keys[v] : 0);
    const unmarkedHere = new Map();
    for (let v = 0; v < count; ++v) if (mark(v) === 0) unmarkedHere.set(at(v), (unmarkedHere.get(at(v)) ?? 0) + 1);
    const id = new Array(count);
    const keysHere = new Map();
    const nextKeys = new Map();
    const nextUnmarked = new Map();
    for (let v = 0; v < count; ++v) {
      const k = mark(v);
      if (k >= 2 && p > 0 && (k - 2) % 2 === (p - 1) % 2 && previousKeys.has(k)) id[v] = previousKeys.get(k);
      else if (k === 0 && unmarkedHere.get(at(v)) === 1 && previousUnmarked.get(at(v))?.count === 1) {
        id[v] = previousUnmarked.get(at(v)).id;
      } else if (k >= 2 && keysHere.has(k)) id[v] = keysHere.get(k);
      else id[v] = vertices++;
      if (k >= 2 && !keysHere.has(k)) keysHere.set(k, id[v]);
      if (k >= 2 && (k - 2) % 2 === p % 2 && !nextKeys.has(k)) nextKeys.set(k, id[v]);
      if (k === 0) {
        const slot = nextUnmarked.get(at(v)) ?? { id: id[v], count: 0 };
        slot.count += 1;
        nextUnmarked.set(at(v), slot);
      }
    }
    for (let t = 0; t + 2 < indices.length; t += 3) triangles.push([id[indices[t]], id[indices[t + 1]], id[indices[t + 2]]]);
    previousKeys = nextKeys;
    previousUnmarked = nextUnmarked;
  });
  const edges = new Map();
  for (const t of triangles) {
    for (let c = 0; c < 3; ++c) {
      const a = t[c];
      const b = t[(c + 1) % 3];
      const key = a < b ? `${a},${b}` : `${b},${a}`;
      edges.set(key, (edges.get(key) ?? 0) + 1);
    }
  }
  let boundaryEdges = 0;
  let nonmanifoldEdges = 0;
  for (const uses of edges.values()) {
    if (uses === 1) ++boundaryEdges;
    if (uses > 2) ++nonmanifoldEdges;
  }
  const used = new Set(triangles.flat());
  return {
    primitives: primitives.length,
    vertices: used.size,
    triangles: triangles.length,
    boundaryEdges,
    nonmanifoldEdges,
    euler: used.size - edges.size + triangles.length,
  };
}

const { json: gltfJson, bin } = glbChunks(bytes);
// Several meshes (label surfaces): each welded on its own, as its chunks' seams are its own.
const several = (gltfJson.meshes ?? []).length > 1;
const welded = several ? null : weld(gltfJson, bin);
const meshes = several ? gltfJson.meshes.map((m) => ({ name: m.name, welded: weld(gltfJson, bin, m.primitives) })) : null;

const loader = new GLTFLoader();
loader.setDRACOLoader(new NodeDracoLoader());
const gltf = await loader.parseAsync(bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + bytes.byteLength), '');
let triangles = 0;
let primitives = 0;
gltf.scene.traverse((o) => {
  if (o.isMesh) {
    primitives += 1;
    triangles += o.geometry.index ? o.geometry.index.count / 3 : o.geometry.attributes.position.count / 3;
  }
});
const box = new Box3().setFromObject(gltf.scene);
// Per named node of a mesh, as three.js shows it: its colour (sRGB hex) and triangles.
const nodes = {};
gltf.scene.traverse((o) => {
  if (!o.isMesh) return;
  // A mesh of several primitives is a Group (the node) of one Mesh per primitive.
  const name = o.parent?.isGroup ? o.parent.name : o.name;
  const entry = nodes[name] ?? (nodes[name] = { color: o.material.color.getHexString(), triangles: 0 });
  entry.triangles += o.geometry.index ? o.geometry.index.count / 3 : o.geometry.attributes.position.count / 3;
});
console.log(JSON.stringify({
  errors: report.issues.numErrors,
  warnings: report.issues.numWarnings,
  messages: report.issues.messages.map((x) => `${x.code}: ${x.message}`),
  triangles,
  primitives,
  min: box.isEmpty() ? null : box.min.toArray(),
  max: box.isEmpty() ? null : box.max.toArray(),
  extras: gltf.asset.extras ?? null,
  welded,
  meshes,
  nodes,
}));
