// The in-browser motion player of the GestureLSM page: every method's body side by side, skinned by three.js
// from the generated joint rotations, driven by one clock (the speech's <audio> element), orbit camera.
// Bundled with three.js into ../dist/player.js by esbuild (entry index.js, scripts/setup.sh); no network at run
// time. The page's player is window.gesturelsmPlayer (index.js).
//
// API (also for a live tab that streams motion, live_feed.js):
//   const p = new MotionPlayer(element)                   // builds canvas, controls, labels inside element
//   await p.setBodies([{label, body: glbUrl}], fps=30)     // rest bodies (GLB cached per URL), frames cleared
//   await p.setBodies(specs, fps, payload.character)      // the methods on the visitor's character (character.js)
//   p.appendFrames(i, rotations, root, expressions)       // Float32Arrays: (n, 55, 4) x,y,z,w; (n, 3); (n, E)
//   p.appendRecord(i, record)                             // a decoded motion record (motion_decoder.js); on a
//                                                         // streamed character body, its character section
//   p.attachClock(clock)                                  // anything with currentTime (s), paused, play(), pause()
//   p.play(); p.pause(); p.seek(seconds)
//   await p.load(payload)                                 // the page: payload of gesturelsm/export/player_payload.py,
//                                                         // again with more bodies as they are made (progressive.js)
//   p.measure = true                                      // benchmarks: timings in p.prof and data-marks (measure.js)
// Bodies that join a running clock (a request whose methods finish one by one, an edited motion beside the
// original): a spec with `pending: true` is a slot (its label only, nothing drawn, no frames) until
//   p.join(i, record)                                     // slot i gets its body and motion and moves at once, at
//                                                         // the clock's current time: nothing restarts or jumps
//   p.join(i, null, characterPayload)                     // the same on the character (its method's frames inside)
//   p.fail(i, message)                                    // slot i says why no motion comes
// Frame shown = floor(clock.currentTime * fps), clamped to the frames of the bodies that move, so motion and speech
// stay within one frame of each other whatever the clock does (play, scrub, seek, stall).
// Test contract on the element: data-state = empty | loading | playing | paused (playing from the first body that
// moves), data-bodies = bodies moving now, data-frames = motion frames drawn so far, data-frame = index of the frame
// on screen, data-fps = draws in the last second, data-character = the file name of the character on screen
// (absent: the mannequin), data-failed = slots whose motion failed (absent: none), data-edit-start / data-edit-end =
// the edit range drawn on the timeline, data-ab = edited | original: which motion an edited body shows (absent:
// nothing edited). An edited payload's `compare` ({index, method, motion}) is the motion before the edit of body
// `index`: the A/B button (#edit-ab) swaps that body between it and the edited one on the same clock (on a
// character: the payload's character methods `method` and `method:before`).
import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { Body, JOINTS, Pending, clayMatcap, loadGlb } from './body.js';
import { CharacterBody, fetchCharacter } from './character.js';
import { adoptStyles, el } from './dom.js';
import { drawProfile, lap, requested } from './measure.js';
import { decodeMotion } from './motion_decoder.js';
import { loadPayload } from './progressive.js';

const SPACING = 1.2;           // metres between bodies, as in the server-side video
// What the camera frames (metres): from just below the floor to above the labels over the heads, and half a body's
// reach beside the outer bodies; the bodies fill the picture's height (MotionPlayer.frameBodies)
const FRAME_TOP = 2.05, FRAME_BOTTOM = -0.12, REACH = 0.6;
const LABEL_ABOVE = 0.22;      // metres above the head joint where a label's bottom edge sits (clear of the face)

export class MotionPlayer {
  constructor(element, { width = 640, height = 360 } = {}) {  // drawing size; CSS scales it
    adoptStyles();
    this.element = element;
    this.fps = 30; this.bodies = []; this.clock = null; this.shown = -1; this.drawn = 0;
    this.dirty = true; this.draws = []; this.generation = 0;
    this.live = null;                                  // the page's live feed (index.js), on the page's player
    this.prof = null; this.marks = null;
    this.measure = requested();
    element.innerHTML = '';
    element.classList.add('motion-player');
    const stage = el('div', { class: 'mp-stage' }, element);
    this.renderer = new THREE.WebGLRenderer({ antialias: false, powerPreference: 'high-performance' });
    this.renderer.setPixelRatio(1);
    this.renderer.setSize(width, height, false);       // the drawing buffer; its size on the page is player.css's
    new ResizeObserver(() => { this.dirtyLayout = true; this.dirty = true; }).observe(this.renderer.domElement);
    stage.appendChild(this.renderer.domElement);
    this.labelBox = el('div', { class: 'mp-labels' }, stage);
    this.scene = new THREE.Scene();
    this.scene.background = new THREE.Color(0xf4f4f2);
    this.scene.add(new THREE.HemisphereLight(0xffffff, 0x8d8a84, 2.2));
    const sun = new THREE.DirectionalLight(0xffffff, 1.6); sun.position.set(1.5, 3, 4); this.scene.add(sun);
    const floor = new THREE.Mesh(new THREE.CircleGeometry(4, 48), new THREE.MeshBasicMaterial({ color: 0xdcdad5 }));
    floor.rotation.x = -Math.PI / 2; this.scene.add(floor);
    this.material = new THREE.MeshMatcapMaterial({ matcap: clayMatcap() });   // lit look, no light maths
    this.camera = new THREE.PerspectiveCamera(30, width / height, 0.05, 50);
    this.controls = new OrbitControls(this.camera, this.renderer.domElement);
    this.frameBodies(1);
    this.controls.addEventListener('change', () => { this.dirty = true; });
    const bar = el('div', { class: 'mp-bar' }, element);
    this.button = el('button', { class: 'mp-play', type: 'button', text: 'Play' }, bar);
    const seek = el('div', { class: 'mp-seek-box' }, bar);
    this.range = el('input', { class: 'mp-seek', type: 'range', min: '0', max: '0', step: '0.001', value: '0' }, seek);
    this.band = el('div', { class: 'mp-edit-range' }, seek);
    this.time = el('span', { class: 'mp-time', text: '0.00 / 0.00 s' }, bar);
    this.ab = el('button', { class: 'mp-ab', type: 'button', text: 'A/B: edited' }, bar);
    if (element.id === 'motion-player') this.ab.id = 'edit-ab';          // the page's player (not the Live tab's)
    this.ab.addEventListener('click', () => this.toggleCompare());
    this.editRange = null; this.compare = null; this.records = [];
    this._showCompare();
    this.button.addEventListener('click', () => (this.clock && this.clock.paused ? this.play() : this.pause()));
    this.range.addEventListener('input', () => this.seek(parseFloat(this.range.value)));
    this.audio = el('audio', { class: 'mp-audio', preload: 'auto' }, element);
    this.audio.addEventListener('ended', () => this._state());
    this.audio.addEventListener('pause', () => this._state());
    this.audio.addEventListener('playing', () => this._state());
    this._setState('empty');
    const tick = () => { this._frame(); this.raf = requestAnimationFrame(tick); };
    this.raf = requestAnimationFrame(tick);
  }

  // ---- API -----------------------------------------------------------------------------------------------
  get measure() { return this.prof !== null; }

  set measure(on) {                                  // measure.js: draw timings in prof, load marks in data-marks
    this.prof = on ? drawProfile() : null;
    if (!on) { this.marks = null; delete this.element.dataset.marks; }
  }

  async setBodies(specs, fps = 30, character = null) {
    const gen = ++this.generation;
    this._setState('loading');
    this.element.dataset.bodies = '0';                     // nothing moves until the new bodies are loaded
    const gltfs = await Promise.all(specs.map((s) => loadGlb(s.body)));
    const ch = character ? await fetchCharacter(character).catch((e) => {     // it cannot load: the mannequin
      this.element.dataset.characterError = String(e.message || e);
      return null;
    }) : null;
    if (gen !== this.generation) return false;            // a newer request replaced these bodies
    for (const b of this.bodies) this.scene.remove(b.root);
    if (this.idleBody) { this.scene.remove(this.idleBody.root); this.idleBody = null; }
    this.labelBox.innerHTML = '';
    this.fps = fps; this.shown = -1; this.drawn = 0;
    this.specs = specs; this.gltfs = gltfs; this.ch = ch; this.chSpec = character;
    const n = specs.length;
    this.labelBox.style.setProperty('--mp-bodies', String(Math.max(n, 1)));
    if (ch) this.element.dataset.character = character.name;
    else delete this.element.dataset.character;
    delete this.element.dataset.failed;
    this.bodies = specs.map((s, i) => {
      const b = s.pending ? new Pending(this._x(i)) : this._body(i, ch ? character : null);
      this.scene.add(b.root);
      b.tag = this._tag(s.label, s.pending ? 'mp-label-pending' : '');
      if (s.pending) { el('br', {}, b.tag); el('span', { class: 'mp-label-wait', text: 'generating...' }, b.tag); }
      return b;
    });
    this._count();
    this.frameBodies(n);
    this.dirty = true;
    return true;
  }

  // The camera looks at n bodies side by side so that they fill the picture: feet on the floor at the bottom, the
  // labels over the heads at the top, the outer bodies' reach inside the sides (the visitor may orbit from there).
  frameBodies(n) {
    const t = Math.tan(THREE.MathUtils.degToRad(this.camera.fov / 2));
    const halfW = ((Math.max(n, 1) - 1) * SPACING) / 2 + REACH, halfH = (FRAME_TOP - FRAME_BOTTOM) / 2;
    const d = Math.max(halfH / t, halfW / (t * this.camera.aspect));
    const y = (FRAME_TOP + FRAME_BOTTOM) / 2;
    this.camera.position.set(0, y, d); this.controls.target.set(0, y, 0); this.controls.update();
  }

  // The bodies of the player, standing at rest (arms down, feet on the floor) until motion comes: the Live tab's
  // body before a stream, and the page's before the first request. Drawn at once.
  standIdle() {
    for (const b of this.bodies) if (b.idle) b.idle();
    this.renderer.render(this.scene, this.camera);
    this._labels();
  }

  // Slot i's body joins the clock where it is now: its motion (a decoded record for the mannequin, or the page's
  // character payload holding the method's frames) is in at once, so the next draw poses it at the shared frame.
  join(i, record, character = null) {
    const old = this.bodies[i];
    const b = this._body(i, this.ch && character ? character : null);
    b.tag = old.tag; b.tag.classList.remove('mp-label-pending');
    const wait = b.tag.querySelector('.mp-label-wait');
    if (wait) { wait.previousSibling.remove(); wait.remove(); }
    this.scene.remove(old.root); this.scene.add(b.root);
    this.bodies[i] = b;
    if (record) this.records[i] = record;
    if (record && !(this.ch && character)) this.appendRecord(i, record, this.specs[i].motion);
    this.range.max = String(this.frames() / this.fps);
    this._count();
    this.shown = -1; this.dirty = true;                  // the next draw poses every body, the new one too
  }

  // Slot i has no motion coming: its label says why (the others play on).
  fail(i, message) {
    const b = this.bodies[i];
    if (!b.pending || b.failed) return;
    b.failed = message;
    b.tag.classList.replace('mp-label-pending', 'mp-label-failed');
    const why = b.tag.querySelector('.mp-label-wait') || el('span', {}, b.tag);
    why.className = 'mp-label-why'; why.textContent = `failed: ${message}`;
    this.element.dataset.failed = String(this.bodies.filter((x) => x.failed).length);
    this.dirty = true;
  }

  _x(i) { return (i - (this.specs.length - 1) / 2) * SPACING; }

  _body(i, character) {
    const s = this.specs[i];
    return character ? new CharacterBody(this.ch, character, s.method, this._x(i))
      : new Body(this.gltfs[i], s.label, this._x(i), this.material);
  }

  // "GestureLSM 8 steps CFG 2" -> method on the first line, settings on the second
  _tag(label, cls) {
    const tag = el('div', { class: `mp-label ${cls}`.trim() }, this.labelBox);
    const m = /^(\D+?)\s+(\d.*)$/.exec(label);
    tag.textContent = m ? m[1] : label;
    if (m) { el('br', {}, tag); el('span', { class: 'mp-label-settings', text: m[2] }, tag); }
    return tag;
  }

  _count() {
    const n = this.bodies.filter((b) => !b.pending && b.frames > 0).length;
    if (this.element.dataset.bodies !== String(n)) this.element.dataset.bodies = String(n);
  }

  appendFrames(i, rotations, root, expressions = null) {
    const b = this.bodies[i];
    const E = expressions ? expressions.length / (rotations.length / (JOINTS * 4)) : 0;
    b.append(rotations, root, expressions || new Float32Array(0), E);
    this.range.max = String(this.frames() / this.fps);
    this._count();
    this.dirty = true;
  }

  // A decoded motion record (motion_decoder.js) for body i; `source` names it in the error for other motion.
  appendRecord(i, record, source = 'motion') {
    const b = this.bodies[i];
    if (b.streamed) {                                  // the live stream on the visitor's character
      if (!record.character || record.character.bones !== b.payload.nodes.length) {
        throw new Error(`${source}: no frames for the ${b.payload.nodes.length} bones of the character`);
      }
      b.appendBones(record.character.rotations, record.character.root, record.character.morph);
      this.range.max = String(this.frames() / this.fps);
      this._count();
      this.dirty = true;
      return;
    }
    if (record.kind !== 'quaternion' || record.joints !== JOINTS) {
      throw new Error(`${source}: ${record.kind} motion of ${record.joints} joints; the player draws quaternion ` +
        `motion of ${JOINTS} joints`);
    }
    this.appendFrames(i, record.rotations, record.root, record.expressionCount ? record.expressions : null);
  }

  attachClock(clock) { this.clock = clock; this.dirty = true; this._state(); }

  frames() {                                         // runs every animation frame: no allocation
    let n = Infinity;
    for (const b of this.bodies) if (!b.pending) n = Math.min(n, b.frames);
    return n === Infinity ? 0 : n;
  }

  async play() {
    if (!this.clock) return;
    try { await this.clock.play(); } catch (e) { /* autoplay refused: the visitor presses Play */ }
    this._state();
  }

  pause() { if (this.clock) this.clock.pause(); this._state(); }

  seek(t) {
    if (!this.clock) return;
    this.clock.currentTime = Math.max(0, Math.min(t, this.frames() / this.fps));
    this.dirty = true;
  }

  // Load and compile a body before any motion exists, so the first payload only fetches motion files.
  async preload(url) {
    const gltf = await loadGlb(url);
    const b = new Body(gltf, '', 0, this.material);
    this.scene.add(b.root);
    this.renderer.compile(this.scene, this.camera);
    if (this.bodies.length) this.scene.remove(b.root);   // a payload came first: its bodies are on screen
    else { b.idle(); this.idleBody = b; }                // shown standing at rest until the first payload
    this.renderer.render(this.scene, this.camera);
    this.dirty = true;
  }

  // The page's payload (progressive.js): the speech and one slot per method; each method's body joins the clock
  // as its motion arrives (the same payload again, with more motion files), the first one starts the speech.
  // `payload.resume` (an edit, an undo): the same speech again, so the time on screen and play / pause are kept.
  load(payload) { return loadPayload(this, payload); }

  // ---- edits: the range on the timeline, A/B of an edited body ------------------------------------------------
  currentTime() { return this.clock ? Math.round((this.clock.currentTime || 0) * 100) / 100 : 0; }

  setRange(start, end) {
    const T = this.frames() / this.fps, d = this.element.dataset;
    this.editRange = [start, end];
    if (!(T > 0) || !(start >= 0) || !(end > start)) {
      this.band.style.display = 'none'; delete d.editStart; delete d.editEnd;
      return;
    }
    const a = Math.min(start, T), b = Math.min(end, T);
    this.band.style.display = 'block';               // '' would fall back to player.css's display: none
    this.band.style.left = `${(100 * a) / T}%`; this.band.style.width = `${(100 * (b - a)) / T}%`;
    d.editStart = String(start); d.editEnd = String(end);
  }

  toggleCompare() {
    const c = this.compare;
    if (!c) return;
    c.showing = c.showing === 'edited' ? 'original' : 'edited';
    const b = this.bodies[c.index];
    if (b.payload) b.method = c.showing === 'edited' ? c.method : `${c.method}:before`;   // on the character
    else { b.frames = 0; this.appendRecord(c.index, c.showing === 'edited' ? c.edited : c.original); }
    this.shown = -1; this.dirty = true;
    this._showCompare();
    this._frame();                                   // posed now: the other motion is on screen from this call on
  }

  async _loadCompare(payload, gen) {
    this.compare = null;
    const c = payload.compare;
    if (c) {
      try {
        const r = await fetch(c.motion);
        if (!r.ok) throw new Error(`${c.motion}: HTTP ${r.status}`);
        const original = decodeMotion(await r.arrayBuffer(), c.motion);
        if (gen !== this.generation) return;
        this.compare = { index: c.index, method: c.method, edited: this.records[c.index], original, showing: 'edited' };
      } catch (e) { this.element.dataset.error = String(e.message || e); }
    }
    this._showCompare();
  }

  _showCompare() {
    const c = this.compare;
    this.ab.style.display = c ? '' : 'none';
    if (!c) { delete this.element.dataset.ab; return; }
    this.element.dataset.ab = c.showing;
    this.ab.textContent = c.showing === 'edited' ? 'A/B: edited (show the original)' : 'A/B: original (show the edit)';
  }

  // ---- internals -----------------------------------------------------------------------------------------
  _setState(s) { if (this.element.dataset.state !== s) this.element.dataset.state = s; }

  _state() {
    if (!this.bodies.length || !this.clock) return this._setState(this.bodies.length ? 'loading' : 'empty');
    // HTMLMediaElement: playing once the 'playing' event fired (data arrived), not merely after play()
    const ready = this.clock.readyState === undefined || this.clock.readyState >= 3;
    const playing = !this.clock.paused && !this.clock.ended && ready;
    this._setState(playing ? 'playing' : 'paused');
    const label = playing ? 'Pause' : 'Play';
    if (this.button.textContent !== label) this.button.textContent = label;
  }

  _frame() {
    const T = this.frames();
    if (!T || !this.clock) return;
    const prof = this.prof;                          // null unless measuring
    let t0 = prof ? performance.now() : 0;
    const t = this.clock.currentTime || 0;
    const f = Math.max(0, Math.min(T - 1, Math.floor(t * this.fps + 1e-6)));
    if (f !== this.shown) {
      for (const b of this.bodies) b.pose(f);
      this.shown = f; this.drawn += 1; this.dirty = true;
      if (Math.floor(t * 4) !== this.tick4 || this.clock.paused) {   // the page's layout: 4 times a second
        this.tick4 = Math.floor(t * 4);
        this.range.value = String(t);
        this.time.textContent = `${t.toFixed(2)} / ${(T / this.fps).toFixed(2)} s`;
      }
    }
    if (!this.dirty) return;
    if (prof) t0 = lap(prof, 'pose', t0);
    this.renderer.render(this.scene, this.camera);
    if (prof) t0 = lap(prof, 'render', t0);
    this._labels();
    this.dirty = false;
    const now = performance.now();
    if (prof) { prof.labels += now - t0; prof.draws += 1; }
    this.draws.push(now);
    while (this.draws.length && this.draws[0] < now - 1000) this.draws.shift();
    const d = this.element.dataset;
    d.frames = String(this.drawn); d.frame = String(f);
    if (d.fps !== String(this.draws.length)) d.fps = String(this.draws.length);
    this._state();
    if (prof) lap(prof, 'dom', now);
  }

  _labels() {
    const v = this._v || (this._v = new THREE.Vector3());
    if (!this.stageH || this.dirtyLayout) { this.stageH = this.renderer.domElement.clientHeight; this.dirtyLayout = false; }
    for (const b of this.bodies) {                // layout read once above, writes only here (no forced layout)
      (b.head || b.bones[15]).getWorldPosition(v); v.y += LABEL_ABOVE; v.project(this.camera);   // joint 15: head
      const left = Math.round(((v.x + 1) / 2) * 1000) / 10, top = Math.round(((1 - v.y) / 2) * this.stageH);
      if (left === b.left && top === b.top) continue;                            // unchanged: no style write
      b.left = left; b.top = top;
      b.tag.style.left = `${left}%`; b.tag.style.top = `${top}px`;
    }
  }

  // test and tool helper: the local joint rotations of body i on screen now, 55 x (x, y, z, w)
  jointRotations(i) {
    return this.bodies[i].bones.slice(0, JOINTS).map((b) => b.quaternion.toArray());
  }

  // test and tool helper: world position of joint j of body i on screen now (metres)
  jointWorld(i, j) {
    const v = new THREE.Vector3();
    this.bodies[i].bones[j].getWorldPosition(v);
    return [v.x, v.y, v.z];
  }
}
