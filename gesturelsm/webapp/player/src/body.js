// One body of the player: a skinned SMPL-X mesh (the rest-body GLB of gesturelsm/export/player_payload.py, cloned per
// body) posed by three.js from the generated joint rotations, frame by frame.
import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import * as SkeletonUtils from 'three/addons/utils/SkeletonUtils.js';

export const JOINTS = 55;
const glbCache = new Map();    // url -> Promise<gltf>
const Z_AXIS = new THREE.Vector3(0, 0, 1);
const IDLE_ARMS = 1.2;         // radians the arms are lowered from the bind T-pose at rest (about 70 degrees)

export function loadGlb(url) {
  if (!glbCache.has(url)) glbCache.set(url, new GLTFLoader().loadAsync(url));
  return glbCache.get(url);
}

// A matcap (the colour of a sphere seen from the camera, looked up by the surface normal): clay lit from the
// upper left. One texture read per pixel instead of lighting: SwiftShader (software WebGL) draws it fastest.
export function clayMatcap(size = 128) {
  const c = document.createElement('canvas'); c.width = c.height = size;
  const g = c.getContext('2d');
  const grad = g.createRadialGradient(size * 0.38, size * 0.32, size * 0.04, size / 2, size / 2, size / 2);
  grad.addColorStop(0, '#fbf1e6'); grad.addColorStop(0.45, '#d8c3ad'); grad.addColorStop(0.85, '#9c8672');
  grad.addColorStop(1, '#6f5f51');
  g.fillStyle = grad; g.fillRect(0, 0, size, size);
  const t = new THREE.CanvasTexture(c); t.colorSpace = THREE.SRGBColorSpace;
  return t;
}

export class Body {
  constructor(gltf, label, offset, material) {
    this.root = SkeletonUtils.clone(gltf.scene);
    this.root.position.x = offset;
    this.mesh = null;
    this.root.traverse((o) => {
      if (o.isSkinnedMesh) { this.mesh = o; o.frustumCulled = false; o.material = material; }
    });
    this.bones = this.mesh.skeleton.bones;            // skin joint order = SMPL-X joint order
    this.label = label;
    this.rot = new Float32Array(0); this.pos = new Float32Array(0); this.expr = new Float32Array(0);
    this.frames = 0; this.E = 0; this.cap = 0;
  }

  // Frames go into buffers that double when full, so a long live stream appends in amortised O(chunk), not
  // O(everything so far) per chunk.
  append(rot, pos, expr, E) {
    const n = rot.length / (JOINTS * 4), need = this.frames + n;
    if (E) this.E = E;
    if (need > this.cap || (this.E && this.expr.length < this.cap * this.E)) {
      const cap = Math.max(need, 2 * (this.cap || 0), 64);
      const grow = (a, w) => { const c = new Float32Array(cap * w); c.set(a.subarray(0, this.frames * w)); return c; };
      this.rot = grow(this.rot, JOINTS * 4); this.pos = grow(this.pos, 3);
      if (this.E) this.expr = grow(this.expr.length >= this.frames * this.E ? this.expr : new Float32Array(this.frames * this.E), this.E);
      this.cap = cap;
    }
    this.rot.set(rot, this.frames * JOINTS * 4); this.pos.set(pos, this.frames * 3);
    if (this.E && expr.length) this.expr.set(expr, this.frames * this.E);
    this.frames = need;
  }

  // Standing at rest before any motion: the bind pose (a T-pose with the pelvis at the origin) with the arms
  // lowered along the sides and the whole body lifted onto the floor (its lowest skinned vertex at y = 0).
  idle() {
    for (const b of this.bones) b.quaternion.identity();
    this.bones[16].quaternion.setFromAxisAngle(Z_AXIS, -IDLE_ARMS);      // left shoulder (the body faces +z)
    this.bones[17].quaternion.setFromAxisAngle(Z_AXIS, IDLE_ARMS);       // right shoulder
    this.bones[18].quaternion.setFromAxisAngle(Z_AXIS, -0.15);
    this.bones[19].quaternion.setFromAxisAngle(Z_AXIS, 0.15);
    if (this.rest0 === undefined) this.rest0 = this.bones[0].position.y;
    this.bones[0].position.y = this.rest0;
    this.root.updateMatrixWorld(true);
    const low = new THREE.Box3().setFromObject(this.mesh, true).min.y;
    this.bones[0].position.y = this.rest0 - low;
    this.root.updateMatrixWorld(true);
  }

  pose(f) {
    const r = this.rot, o = f * JOINTS * 4;
    for (let j = 0; j < JOINTS; j++) this.bones[j].quaternion.set(r[o + 4 * j], r[o + 4 * j + 1], r[o + 4 * j + 2], r[o + 4 * j + 3]);
    this.bones[0].position.set(this.pos[3 * f], this.pos[3 * f + 1], this.pos[3 * f + 2]);
    const infl = this.mesh.morphTargetInfluences;
    if (infl && this.E) for (let e = 0; e < Math.min(this.E, infl.length); e++) infl[e] = this.expr[f * this.E + e];
  }
}

// A body's place while its motion is being generated (MotionPlayer.setBodies with a pending spec): nothing drawn,
// its label above where the head will be, no frames (the shared clock is bounded by the bodies that move).
export class Pending {
  constructor(offset) {
    this.root = new THREE.Group();
    this.root.position.x = offset;
    this.head = new THREE.Object3D();
    this.head.position.y = 1.45;
    this.root.add(this.head);
    this.frames = 0; this.pending = true;
  }

  append() {}

  pose() {}
}
