// The user's character in the browser: a VRM (0.x or 1.0) or a skinned glTF loaded with three.js'
// GLTFLoader and @pixiv/three-vrm, animated either by the glTF animation the server wrote into the file
// (`gesturelsm export --rig`) or by per-bone rotations streamed from the server (gesturelsm/webapp/character.py).
// A character whose VRM presets bind visemes or blink also gets the face's morph-target weights: the payload's
// `morphs` lists the channels [[glTF mesh index, morph target index], ...] and each frame holds one weight per channel,
// set as morphTargetInfluences[target] of every three.js Mesh of that glTF mesh (one per primitive).
import * as THREE from 'three';
import { GLTFLoader } from 'three/examples/jsm/loaders/GLTFLoader.js';
import * as SkeletonUtils from 'three/examples/jsm/utils/SkeletonUtils.js';
import { VRMLoaderPlugin } from '@pixiv/three-vrm';

/** Parse a .vrm / .glb file's bytes. Resolves to {gltf, vrm (null for plain glTF), scene, mixer, clip}. */
export async function loadCharacter(bytes) {
  const loader = new GLTFLoader();
  loader.register((parser) => new VRMLoaderPlugin(parser, { autoUpdateHumanBones: false }));
  const gltf = await loader.parseAsync(bytes, '');
  const vrm = gltf.userData.vrm || null;
  const scene = vrm ? vrm.scene : gltf.scene;
  const mixer = new THREE.AnimationMixer(scene);
  const clip = gltf.animations.find((a) => a.name === 'gesturelsm') || gltf.animations[0] || null;
  if (clip) mixer.clipAction(clip).play();
  return { gltf, vrm, scene, mixer, clip };
}

/** Pose the character at time t (seconds) of its animation and update world matrices. */
export function seek(character, t) {
  if (character.clip) character.mixer.setTime(Math.min(t, character.clip.duration));
  character.scene.updateMatrixWorld(true);
}

/** The raw (file) node of a VRM humanoid bone ('rightHand', ...), or a node found by name in plain glTF. */
export function boneNode(character, name) {
  if (character.vrm) return character.vrm.humanoid.getRawBoneNode(name);
  return character.scene.getObjectByName(name) || null;
}

/** World position [x, y, z] of a humanoid bone after `seek`. */
export function boneWorldPosition(character, name) {
  const node = boneNode(character, name);
  if (!node) return null;
  const v = new THREE.Vector3();
  node.getWorldPosition(v);
  return [v.x, v.y, v.z];
}

/** The three.js object of each glTF node index (GLTFLoader's associations; names may have been rewritten). */
export function nodeObjects(character) {
  if (!character.nodes) {
    character.nodes = new Map();
    character.gltf.parser.associations.forEach((v, obj) => {
      if (v && v.nodes !== undefined && !character.nodes.has(v.nodes)) character.nodes.set(v.nodes, obj);
    });
  }
  return character.nodes;
}

/**
 * Apply one frame of streamed rotations: `nodes` lists glTF node indices (hips first), `quats` holds
 * (x, y, z, w) per node, `root` (optional) the hips' local translation [x, y, z].
 */
export function applyFrame(character, nodes, quats, root) {
  const objects = nodeObjects(character);
  nodes.forEach((n, k) => {
    const obj = objects.get(n);
    if (obj) obj.quaternion.set(quats[4 * k], quats[4 * k + 1], quats[4 * k + 2], quats[4 * k + 3]);
  });
  const hips = nodes.length ? objects.get(nodes[0]) : null;
  if (root && hips) hips.position.set(root[0], root[1], root[2]);
  character.scene.updateMatrixWorld(true);
}

/** The three.js Meshes of each glTF mesh index (a multi-primitive mesh is several; GLTFLoader's associations). */
export function meshObjects(character) {
  const out = new Map();
  character.gltf.parser.associations.forEach((v, obj) => {
    if (v && v.meshes !== undefined && obj.isMesh) {
      if (!out.has(v.meshes)) out.set(v.meshes, []);
      out.get(v.meshes).push(obj);
    }
  });
  return out;
}

/**
 * Set one frame of face weights: `channels` [[mesh, target], ...], `weights` one number per channel; `meshes` maps
 * glTF mesh indices to their three.js Meshes (meshObjects). Targets a Mesh does not have are left alone.
 */
export function applyMorph(meshes, channels, weights) {
  channels.forEach(([m, k], j) => {
    for (const obj of meshes.get(m) || []) {
      if (obj.morphTargetInfluences && k < obj.morphTargetInfluences.length) obj.morphTargetInfluences[k] = weights[j];
    }
  });
}

/** Decode a base64 float32 array from gesturelsm/webapp/character.py's payload. */
export function decodeFloats(b64) {
  const bin = atob(b64);
  const bytes = new Uint8Array(bin.length);
  for (let i = 0; i < bin.length; i++) bytes[i] = bin.charCodeAt(i);
  return new Float32Array(bytes.buffer);
}

/**
 * Pose the character at `frame` of one method of the server's payload
 * ({name, bones, nodes, fps, frames, morphs?, methods: {method: {quats, root, morph?}}}); decoded arrays are cached on
 * it. `meshes` (meshObjects of `character`) gets the face's weights when the payload has them.
 * The player sets #motion-player[data-character] = payload.name when it shows the character.
 */
export function showPayloadFrame(character, payload, method, frame, meshes = null) {
  const m = payload.methods[method];
  if (!m) return;
  if (!m._q) { m._q = decodeFloats(m.quats); m._r = decodeFloats(m.root); }
  if (m.morph && !m._w) m._w = decodeFloats(m.morph);
  const B = payload.nodes.length;
  const f = Math.max(0, Math.min(payload.frames - 1, frame | 0));
  if (m._w && meshes) {
    const F = payload.morphs.length;
    applyMorph(meshes, payload.morphs, m._w.subarray(F * f, F * (f + 1)));
  }
  applyFrame(character, payload.nodes, m._q.subarray(4 * B * f, 4 * B * (f + 1)), m._r.subarray(3 * f, 3 * f + 3));
}

const characters = new Map();  // payload key (a hash of the file) -> Promise<character>

/** The page's character of a payload ({url, key}), fetched and parsed once per file. */
export function fetchCharacter(spec) {
  if (!characters.has(spec.key)) {
    const p = fetch(spec.url).then((r) => {
      if (!r.ok) throw new Error(`${spec.url}: HTTP ${r.status}`);
      return r.arrayBuffer();
    }).then(loadCharacter);
    p.catch(() => characters.delete(spec.key));          // a failed load is tried again by the next request
    characters.set(spec.key, p);
  }
  return characters.get(spec.key);
}

/**
 * One method of the player on the character (player.js draws these instead of the mannequin's Body): a clone of
 * the loaded character turned into the player's world (`align`, `1 / scale`: SMPL-X axes, metres), posed at
 * frame f from the payload's rotations of `method`. A payload without that method is a live stream's
 * (live_feed.js): its frames come with appendBones, chunk by chunk, from the motion records' character section.
 */
export class CharacterBody {
  constructor(base, payload, method, offset) {
    const scene = SkeletonUtils.clone(base.scene);
    const copies = [], of = new Map();
    scene.traverse((o) => { copies.push(o); o.frustumCulled = false; });
    let k = 0;
    base.scene.traverse((o) => of.set(o, copies[k++]));      // a clone keeps the order of the hierarchy
    const nodes = new Map(), meshes = new Map();
    nodeObjects(base).forEach((obj, n) => { if (of.has(obj)) nodes.set(n, of.get(obj)); });
    meshObjects(base).forEach((objs, m) => meshes.set(m, objs.filter((o) => of.has(o)).map((o) => of.get(o))));
    this.meshes = meshes;                                      // glTF mesh index -> this clone's three.js Meshes
    this.character = { gltf: base.gltf, vrm: null, scene, nodes };
    scene.quaternion.fromArray(payload.align);
    scene.scale.setScalar(1 / payload.scale);
    this.root = new THREE.Group();
    this.root.add(scene);
    this.root.position.x = offset;
    this.head = nodes.get(payload.nodes[payload.head]) || scene;     // the label stands above it
    this.payload = payload; this.method = method;
    this.streamed = !(payload.methods && payload.methods[method]);
    this.frames = this.streamed ? 0 : payload.frames;
    this.morphs = payload.morphs || [];                          // the face's channels [[mesh, target], ...]
    this.q = new Float32Array(0); this.r = new Float32Array(0); this.w = new Float32Array(0); this.cap = 0;
  }

  append() {}                    // the mannequin's arrays: not drawn on the character

  // A streamed chunk: quats (n, B, 4), the hips' translation (n, 3) and the face's weights (n, F), F = the channels of
  // the stream's first message (payload.morphs); buffers double when full (as Body's).
  appendBones(quats, root, morph = null) {
    const B = this.payload.nodes.length, F = this.morphs.length, n = root.length / 3, need = this.frames + n;
    if (quats.length !== n * B * 4) throw new Error(`a chunk of ${quats.length / 4} bone rotations for ${n} frames of ${B} bones`);
    const got = morph ? morph.length : 0;
    if (got !== n * F) throw new Error(`a chunk of ${got} face weights for ${n} frames of ${F} morph channels`);
    if (need > this.cap) {
      const cap = Math.max(need, 2 * this.cap, 64);
      const grow = (a, w) => { const c = new Float32Array(cap * w); c.set(a.subarray(0, this.frames * w)); return c; };
      this.q = grow(this.q, 4 * B); this.r = grow(this.r, 3); this.w = grow(this.w, F); this.cap = cap;
    }
    this.q.set(quats, this.frames * 4 * B); this.r.set(root, this.frames * 3);
    if (F) this.w.set(morph, this.frames * F);
    this.frames = need;
  }

  pose(f) {
    if (!this.streamed) return showPayloadFrame(this.character, this.payload, this.method, f, this.meshes);
    const B = this.payload.nodes.length, F = this.morphs.length;
    if (F) applyMorph(this.meshes, this.morphs, this.w.subarray(F * f, F * (f + 1)));
    applyFrame(this.character, this.payload.nodes, this.q.subarray(4 * B * f, 4 * B * (f + 1)), this.r.subarray(3 * f, 3 * f + 3));
  }
}
