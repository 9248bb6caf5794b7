// The page's decoder of the binary motion format (layout and encoder: gesturelsm/export/motion_codec.py): the
// offline player's motion files and the live feed's WebSocket messages are both one record,
//   header (28 bytes, little-endian): magic "GLSM", version u16, kind u16 (1 quaternion, 2 axis-angle),
//     joints u16, expressions u16, fps f32, start u32, frames u32, meta bytes u32
//   float32 rotations (frames, joints, 4 or 3), root (frames, 3), expressions (frames, E); meta (UTF-8 JSON).
// Version 2 adds a character section (the live feed on the visitor's character): after the header, bones u16 (B) and
// morph channels u16 (F, 0: none); after the expressions, float32 bone rotations (frames, B, 4), the hips' translation
// (frames, 3) and the face's morph-target weights (frames, F), in the order of the stream's first message's
// meta.character.morphs ([[glTF mesh, target], ...]).
// The float arrays are views into the buffer (no copy) on little-endian machines (all browsers' platforms).

export const MAGIC = 'GLSM';
export const VERSION = 1;                 // no character section
export const CHARACTER_VERSION = 2;       // with one
export const HEADER_BYTES = 28;
const KINDS = { 1: 'quaternion', 2: 'axis-angle' };
const CHANNELS = { quaternion: 4, 'axis-angle': 3 };
const LITTLE_ENDIAN = new Uint8Array(new Uint16Array([1]).buffer)[0] === 1;

// ArrayBuffer -> {version, kind, joints, expressionCount, fps, start, frames, rotations, root, expressions, meta,
// character: null or {bones, rotations, root, morphs: F, morph: (frames, F) floats}};
// throws an Error naming `source` and what is wrong when the bytes are not a record this decoder knows.
export function decodeMotion(buffer, source = 'motion data') {
  if (ArrayBuffer.isView(buffer)) buffer = buffer.buffer.slice(buffer.byteOffset, buffer.byteOffset + buffer.byteLength);
  const size = buffer.byteLength;
  if (size < HEADER_BYTES) {
    throw new Error(`${source}: ${size} bytes, shorter than the ${HEADER_BYTES}-byte header of a GestureLSM motion record`);
  }
  const v = new DataView(buffer);
  const magic = String.fromCharCode(...new Uint8Array(buffer, 0, 4));
  if (magic !== MAGIC) throw new Error(`${source}: not a GestureLSM motion record (it starts with ${JSON.stringify(magic)}, not "${MAGIC}")`);
  const version = v.getUint16(4, true);
  if (version !== VERSION && version !== CHARACTER_VERSION) {
    throw new Error(`${source}: motion format version ${version}; this player knows versions ${VERSION} and ` +
      `${CHARACTER_VERSION} (reload the page)`);
  }
  const code = v.getUint16(6, true), kind = KINDS[code];
  if (!kind) throw new Error(`${source}: unknown motion kind ${code} (1 = quaternion, 2 = axis-angle)`);
  const joints = v.getUint16(8, true), E = v.getUint16(10, true), fps = v.getFloat32(12, true);
  const start = v.getUint32(16, true), frames = v.getUint32(20, true), metaBytes = v.getUint32(24, true);
  const sectioned = version === CHARACTER_VERSION;
  if (sectioned && size < HEADER_BYTES + 4) throw new Error(`${source}: ${size} bytes, shorter than the headers of a version 2 record`);
  const B = sectioned ? v.getUint16(HEADER_BYTES, true) : 0;
  const F = sectioned ? v.getUint16(HEADER_BYTES + 2, true) : 0;
  const widths = [joints * CHANNELS[kind], 3, E, ...(sectioned ? [4 * B, 3, F] : [])];
  let off = HEADER_BYTES + (sectioned ? 4 : 0);
  const want = off + 4 * frames * widths.reduce((a, b) => a + b, 0) + metaBytes;
  if (size !== want) {
    throw new Error(`${source}: ${size} bytes, but its header says ${want} (${frames} frames of ${joints} joints, ` +
      `${E} expressions, ${B} character bones and ${F} morph weights, ${metaBytes} bytes of meta): ` +
      'the data is cut or padded');
  }
  const [rotations, root, expressions, boneRotations, boneRoot, morph] = widths.map((w) => {
    const n = frames * w, at = off;
    off += 4 * n;
    if (LITTLE_ENDIAN) return new Float32Array(buffer, at, n);
    const a = new Float32Array(n);
    for (let k = 0; k < n; k++) a[k] = v.getFloat32(at + 4 * k, true);
    return a;
  });
  let meta = {};
  if (metaBytes) {
    try {
      meta = JSON.parse(new TextDecoder('utf-8', { fatal: true }).decode(new Uint8Array(buffer, off, metaBytes)));
    } catch (e) {
      throw new Error(`${source}: its meta block is not UTF-8 JSON`);
    }
    if (!meta || typeof meta !== 'object' || Array.isArray(meta)) throw new Error(`${source}: its meta block is not a JSON object`);
  }
  const character = sectioned ? { bones: B, rotations: boneRotations, root: boneRoot, morphs: F, morph } : null;
  return { version, kind, joints, expressionCount: E, fps, start, frames, rotations, root, expressions, meta, character };
}
