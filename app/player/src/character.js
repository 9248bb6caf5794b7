// The user's character in the browser: a VRM (0.x or 1.0) or a skinned glTF loaded with three.js'
// GLTFLoader and @pixiv/three-vrm, animated either by the glTF animation the server wrote into the file
// (`gesturelsm export --rig`) or by per-bone rotations streamed from the server (app/character.py).
import * as THREE from 'three';
import { GLTFLoader } from 'three/examples/jsm/loaders/GLTFLoader.js';
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

/**
 * Apply one frame of streamed rotations: `bones` lists node names, `quats` is a Float32Array of
 * (x, y, z, w) per bone, `root` (optional) the hips' local translation [x, y, z].
 */
export function applyFrame(character, bones, quats, root) {
  bones.forEach((name, k) => {
    const node = character.scene.getObjectByName(name);
    if (node) node.quaternion.set(quats[4 * k], quats[4 * k + 1], quats[4 * k + 2], quats[4 * k + 3]);
  });
  if (root && bones.length) {
    const hips = character.scene.getObjectByName(bones[0]);
    if (hips) hips.position.set(root[0], root[1], root[2]);
  }
  character.scene.updateMatrixWorld(true);
}
