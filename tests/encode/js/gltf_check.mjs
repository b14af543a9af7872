// Loads a .glb with real clients and prints what they saw, as JSON on stdout:
// - the Khronos glTF validator (gltf-validator): error and warning counts, and the messages;
// - three.js: GLTFLoader with a DRACOLoader, triangles and bounding box of the loaded scene.
// three's DRACOLoader decodes in Web Workers, which Node lacks; NodeDracoLoader keeps its
// interface and decodes in this thread with the same Draco decoder module (draco3d).
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
console.log(JSON.stringify({
  errors: report.issues.numErrors,
  warnings: report.issues.numWarnings,
  messages: report.issues.messages.map((x) => `${x.code}: ${x.message}`),
  triangles,
  primitives,
  min: box.isEmpty() ? null : box.min.toArray(),
  max: box.isEmpty() ? null : box.max.toArray(),
  extras: gltf.asset.extras ?? null,
}));
