// The in-browser motion player of the GestureLSM page: every method's body side by side, skinned by three.js
// from the generated joint rotations, driven by one clock (the speech's <audio> element), orbit camera.
// Bundled with three.js into ../dist/player.js by esbuild (scripts/setup.sh); no network at run time.
//
// API (also for a live tab that streams motion):
//   const p = new MotionPlayer(element)                   // builds canvas, controls, labels inside element
//   await p.setBodies([{label, body: glbUrl}], fps=30)     // rest bodies (GLB cached per URL), frames cleared
//   p.appendFrames(i, rotations, root, expressions)       // Float32Arrays: (n, 55, 4) x,y,z,w; (n, 3); (n, E)
//   p.attachClock(clock)                                  // anything with currentTime (s), paused, play(), pause()
//   p.play(); p.pause(); p.seek(seconds)
//   await p.load(payload)                                 // the page: payload of gesturelsm/export/player.py
// Frame shown = floor(clock.currentTime * fps), clamped to the frames received so far, so motion and speech
// stay within one frame of each other whatever the clock does (play, scrub, seek, stall).
// Test contract on the element: data-state = empty | loading | playing | paused, data-frames = motion frames
// drawn so far, data-frame = index of the frame on screen, data-fps = draws in the last second.
import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import * as SkeletonUtils from 'three/addons/utils/SkeletonUtils.js';

const JOINTS = 55;
const SPACING = 1.2;           // metres between bodies, as in the server-side video
const glbCache = new Map();    // url -> Promise<gltf>

function loadGlb(url) {
  if (!glbCache.has(url)) glbCache.set(url, new GLTFLoader().loadAsync(url));
  return glbCache.get(url);
}

function el(tag, attrs = {}, parent = null) {
  const e = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs)) (k === 'text' ? (e.textContent = v) : e.setAttribute(k, v));
  if (parent) parent.appendChild(e);
  return e;
}

// A matcap (the colour of a sphere seen from the camera, looked up by the surface normal): clay lit from the
// upper left. One texture read per pixel instead of lighting: SwiftShader (software WebGL) draws it fastest.
function clayMatcap(size = 128) {
  const c = document.createElement('canvas'); c.width = c.height = size;
  const g = c.getContext('2d');
  const grad = g.createRadialGradient(size * 0.38, size * 0.32, size * 0.04, size / 2, size / 2, size / 2);
  grad.addColorStop(0, '#fbf1e6'); grad.addColorStop(0.45, '#d8c3ad'); grad.addColorStop(0.85, '#9c8672');
  grad.addColorStop(1, '#6f5f51');
  g.fillStyle = grad; g.fillRect(0, 0, size, size);
  const t = new THREE.CanvasTexture(c); t.colorSpace = THREE.SRGBColorSpace;
  return t;
}

class Body {
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

  pose(f) {
    const r = this.rot, o = f * JOINTS * 4;
    for (let j = 0; j < JOINTS; j++) this.bones[j].quaternion.set(r[o + 4 * j], r[o + 4 * j + 1], r[o + 4 * j + 2], r[o + 4 * j + 3]);
    this.bones[0].position.set(this.pos[3 * f], this.pos[3 * f + 1], this.pos[3 * f + 2]);
    const infl = this.mesh.morphTargetInfluences;
    if (infl && this.E) for (let e = 0; e < Math.min(this.E, infl.length); e++) infl[e] = this.expr[f * this.E + e];
  }
}

export class MotionPlayer {
  constructor(element, { width = 640, height = 300 } = {}) {  // drawing size; CSS scales it
    this.element = element;
    this.fps = 30; this.bodies = []; this.clock = null; this.shown = -1; this.drawn = 0;
    // ms spent per part of the draws so far (benchmarks/player_latency.py reads it): pose = bones from the
    // motion, render = three.js (skinning + raster, SwiftShader), labels = label positions, dom = data-* + state
    this.prof = { pose: 0, render: 0, labels: 0, dom: 0, draws: 0 };
    this.dirty = true; this.draws = []; this.generation = 0;
    element.innerHTML = '';
    element.classList.add('motion-player');
    const stage = el('div', { class: 'mp-stage', style: 'position:relative' }, element);
    this.renderer = new THREE.WebGLRenderer({ antialias: false, powerPreference: 'high-performance' });
    this.renderer.setPixelRatio(1);
    this.renderer.setSize(width, height);
    this.renderer.domElement.style.width = '100%'; this.renderer.domElement.style.height = 'auto';
    new ResizeObserver(() => { this.dirtyLayout = true; this.dirty = true; }).observe(this.renderer.domElement);
    stage.appendChild(this.renderer.domElement);
    this.labelBox = el('div', { class: 'mp-labels', style: 'position:absolute;inset:0;pointer-events:none' }, stage);
    this.scene = new THREE.Scene();
    this.scene.background = new THREE.Color(0xf4f4f2);
    this.scene.add(new THREE.HemisphereLight(0xffffff, 0x8d8a84, 2.2));
    const sun = new THREE.DirectionalLight(0xffffff, 1.6); sun.position.set(1.5, 3, 4); this.scene.add(sun);
    const floor = new THREE.Mesh(new THREE.CircleGeometry(4, 48), new THREE.MeshBasicMaterial({ color: 0xdcdad5 }));
    floor.rotation.x = -Math.PI / 2; this.scene.add(floor);
    this.material = new THREE.MeshMatcapMaterial({ matcap: clayMatcap() });   // lit look, no light maths
    this.camera = new THREE.PerspectiveCamera(30, width / height, 0.05, 50);
    this.camera.position.set(0, 1.2, 4.6);
    this.controls = new OrbitControls(this.camera, this.renderer.domElement);
    this.controls.target.set(0, 1.0, 0); this.controls.update();
    this.controls.addEventListener('change', () => { this.dirty = true; });
    const bar = el('div', { class: 'mp-bar', style: 'display:flex;gap:8px;align-items:center;margin-top:4px' }, element);
    this.button = el('button', { class: 'mp-play', type: 'button', text: 'Play' }, bar);
    this.range = el('input', { class: 'mp-seek', type: 'range', min: '0', max: '0', step: '0.001', value: '0',
      style: 'flex:1' }, bar);
    this.time = el('span', { class: 'mp-time', text: '0.00 / 0.00 s' }, bar);
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
  async setBodies(specs, fps = 30) {
    const gen = ++this.generation;
    this._setState('loading');
    const gltfs = await Promise.all(specs.map((s) => loadGlb(s.body)));
    if (gen !== this.generation) return false;            // a newer request replaced these bodies
    for (const b of this.bodies) this.scene.remove(b.root);
    this.labelBox.innerHTML = '';
    this.fps = fps; this.shown = -1; this.drawn = 0;
    const n = specs.length;
    this.bodies = specs.map((s, i) => {
      const b = new Body(gltfs[i], s.label, (i - (n - 1) / 2) * SPACING, this.material);
      this.scene.add(b.root);
      b.tag = el('div', { class: 'mp-label', style: 'position:absolute;transform:translateX(-50%);' +
        'font:600 11px sans-serif;background:rgba(255,255,255,.8);padding:1px 4px;border-radius:4px;' +
        `text-align:center;max-width:${Math.floor(90 / Math.max(n, 1))}%` }, this.labelBox);
      // "GestureLSM 8 steps CFG 2" -> method on the first line, settings on the second
      const m = /^(\D+?)\s+(\d.*)$/.exec(s.label);
      b.tag.textContent = m ? m[1] : s.label;
      if (m) { el('br', {}, b.tag); el('span', { text: m[2], style: 'font-weight:400' }, b.tag); }
      return b;
    });
    this.camera.position.set(0, 1.2, 2.6 + 1.4 * Math.max(n, 1)); this.controls.update();
    this.dirty = true;
    return true;
  }

  appendFrames(i, rotations, root, expressions = null) {
    const b = this.bodies[i];
    const E = expressions ? expressions.length / (rotations.length / (JOINTS * 4)) : 0;
    b.append(rotations, root, expressions || new Float32Array(0), E);
    this.range.max = String(this.frames() / this.fps);
    this.dirty = true;
  }

  attachClock(clock) { this.clock = clock; this.dirty = true; this._state(); }

  frames() {                                         // runs every animation frame: no allocation
    let n = Infinity;
    for (const b of this.bodies) n = Math.min(n, b.frames);
    return this.bodies.length ? n : 0;
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
    this.renderer.render(this.scene, this.camera);
    this.scene.remove(b.root);
    this.dirty = true;
  }

  async load(payload) {
    const gen = this.generation + 1;
    const t0 = performance.now();
    this.marks = { start: t0 };
    this.payload = payload;
    this.pause();
    this.audio.src = payload.audio || '';          // the speech loads while bodies and motion do
    const motions = Promise.all(payload.bodies.map((b) => fetch(b.motion).then((r) => {
      if (!r.ok) throw new Error(`${b.motion}: HTTP ${r.status}`);
      return r.arrayBuffer();
    })));
    if (!(await this.setBodies(payload.bodies, payload.fps))) return;
    this.marks.bodies = performance.now() - t0;
    const bufs = await motions;
    if (gen !== this.generation) return;
    this.marks.motion = performance.now() - t0;
    const T = payload.frames;
    bufs.forEach((buf, i) => {
      const E = payload.bodies[i].expressions || 0;
      const a = new Float32Array(buf);
      const nr = T * JOINTS * 4;
      this.appendFrames(i, a.subarray(0, nr), a.subarray(nr, nr + 3 * T), E ? a.subarray(nr + 3 * T, nr + 3 * T + E * T) : null);
    });
    this.audio.currentTime = 0;
    this.attachClock(this.audio);
    await this.play();
    this.marks.play = performance.now() - t0;
    this.element.dataset.marks = JSON.stringify(this.marks);
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
    const t = this.clock.currentTime || 0;
    const f = Math.max(0, Math.min(T - 1, Math.floor(t * this.fps + 1e-6)));
    const pr = this.prof, t0 = performance.now();
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
    const t1 = performance.now();
    this.renderer.render(this.scene, this.camera);
    const t2 = performance.now();
    this._labels();
    this.dirty = false;
    const now = performance.now();
    pr.pose += t1 - t0; pr.render += t2 - t1; pr.labels += now - t2; pr.draws += 1;
    this.draws.push(now);
    while (this.draws.length && this.draws[0] < now - 1000) this.draws.shift();
    const d = this.element.dataset;
    d.frames = String(this.drawn); d.frame = String(f);
    if (d.fps !== String(this.draws.length)) d.fps = String(this.draws.length);
    this._state();
    pr.dom += performance.now() - now;
  }

  _labels() {
    const v = this._v || (this._v = new THREE.Vector3());
    if (!this.stageH || this.dirtyLayout) { this.stageH = this.renderer.domElement.clientHeight; this.dirtyLayout = false; }
    for (const b of this.bodies) {                // layout read once above, writes only here (no forced layout)
      b.bones[15].getWorldPosition(v); v.y += 0.32; v.project(this.camera);      // joint 15: head
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

// One player per element, created on first use; the page calls gesturelsmPlayer.load(payload).
export function mount(element) {
  if (!element.__player) {
    element.__player = new MotionPlayer(element);
    const done = () => { element.dataset.ready = '1'; };
    if (element.dataset.preload) element.__player.preload(element.dataset.preload).then(done, done);
    else done();
  }
  window.gesturelsmPlayer = element.__player;
  return element.__player;
}

// ---- live streaming (the Live tab, app/live.py) -------------------------------------------------------------
// A clock for motion that arrives in chunks while the visitor speaks: frame f is shown at f / fps + delay (seconds of
// performance.now()), where delay is the largest lateness (browser arrival time - first frame / fps) of the last
// LATE_KEEP chunks. Playback runs at 1x, keeps one steady delay behind the voice, and never goes backwards (when the
// delay grows it holds the frame; when it shrinks it skips ahead).
const LATE_KEEP = 8;

export class LiveClock {
  constructor(fps = 30) { this.fps = fps; this.paused = true; this.delay = null; this.late = []; this.t = 0; }

  arrived(firstFrame) {                       // a chunk starting at frame firstFrame has just arrived
    this.late.push(performance.now() / 1000 - firstFrame / this.fps);
    if (this.late.length > LATE_KEEP) this.late.shift();
    this.delay = Math.max(...this.late);
    this.paused = false;
  }

  get currentTime() {
    if (this.delay !== null && !this.paused) this.t = Math.max(this.t, performance.now() / 1000 - this.delay);
    return this.t;
  }

  set currentTime(t) { /* a live stream is not scrubbed */ }
  play() { return Promise.resolve(); }
  pause() { this.paused = true; }
}

// The microphone of the Live tab: an AudioWorklet taps it (at 16 kHz where the browser resamples for us, as
// Chromium and Firefox do) and hands over int16 PCM blocks of SEND_S seconds as they are captured.
const SEND_S = 0.05;
const TAP = `class Tap extends AudioWorkletProcessor {
  constructor(o) { super(); this.n = o.processorOptions.n; this.b = new Float32Array(this.n); this.k = 0; }
  process(inputs) {
    const x = inputs[0] && inputs[0][0];
    if (x) for (let i = 0; i < x.length; i++) {
      this.b[this.k++] = x[i];
      if (this.k === this.n) { this.port.postMessage(this.b, [this.b.buffer]); this.b = new Float32Array(this.n); this.k = 0; }
    }
    return true;
  }
}
registerProcessor('gesturelsm-tap', Tap);`;

export class LiveMic {
  async open() {                         // asks for the microphone; this.rate = the samples per second sent
    this.stream = await navigator.mediaDevices.getUserMedia({ audio: { channelCount: 1 } });
    try { this.ctx = new AudioContext({ sampleRate: 16000 }); } catch (e) { this.ctx = new AudioContext(); }
    this.rate = this.ctx.sampleRate;
    const url = URL.createObjectURL(new Blob([TAP], { type: 'text/javascript' }));
    try { await this.ctx.audioWorklet.addModule(url); } finally { URL.revokeObjectURL(url); }
  }

  start(onBlock) {                       // onBlock(Int16Array) every SEND_S of speech
    const src = this.ctx.createMediaStreamSource(this.stream);
    this.node = new AudioWorkletNode(this.ctx, 'gesturelsm-tap', { channelCount: 1, channelCountMode: 'explicit',
      processorOptions: { n: Math.round(this.rate * SEND_S) } });
    this.node.port.onmessage = (e) => {
      const f = e.data, pcm = new Int16Array(f.length);
      for (let k = 0; k < f.length; k++) pcm[k] = Math.max(-1, Math.min(1, f[k])) * 32767;
      onBlock(pcm);
    };
    const mute = this.ctx.createGain(); mute.gain.value = 0;   // pulled by the graph, heard by nobody
    src.connect(this.node); this.node.connect(mute); mute.connect(this.ctx.destination);
    return this.ctx.resume();
  }

  close() {
    if (this.node) this.node.port.onmessage = null;
    if (this.stream) for (const t of this.stream.getTracks()) t.stop();
    if (this.ctx && this.ctx.state !== 'closed') this.ctx.close();
  }
}

// The live player: a MotionPlayer with one body fed by the server's JSON (app/live.py `payload`), on a LiveClock.
// start() opens the microphone and the app's socket (element data-socket; protocol in app/live_socket.py), streams
// the speech and plays the motion that comes back; stop() sends the end (the server generates the rest, then closes).
// push(json) appends the frames a message carries; reset() starts a
// new stream. The meter: #live-latency = the server's median (ms) from a block's arrival to its motion being ready,
// #live-stats = p90 and real-time factor, #live-status. It also measures the latency the visitor sees: for every newly
// drawn frame f, now - (capture of the first block - SEND_S + f / fps), i.e. from the moment the speech of that
// frame was spoken to the moment its motion is on screen (element data-shown-median-ms and data-shown-p90-ms).
export class LiveFeed {
  constructor(element, bodyUrl, box = document, label = 'live') {
    this.player = new MotionPlayer(element);
    this.element = element; this.bodyUrl = bodyUrl; this.label = label;
    for (const c of ['.mp-play', '.mp-seek']) element.querySelector(c).style.display = 'none';
    this.caption = el('span', { class: 'mp-live', style: 'font:12px sans-serif;margin-left:auto' },
      element.querySelector('.mp-bar'));
    this.ui = Object.fromEntries(['record', 'stop', 'latency', 'stats', 'status'].map((k) => [k, box.querySelector(`#live-${k}`)]));
    if (this.ui.record) this.ui.record.addEventListener('click', () => this.start());
    if (this.ui.stop) this.ui.stop.addEventListener('click', () => this.stop());
    this.ready = this.player.setBodies([{ label, body: bodyUrl }]).then(() => {   // the body at rest until a stream
      this.player.renderer.render(this.player.scene, this.player.camera);
      element.dataset.ready = '1';
    });
    this.spoken0 = null; this.seen = -1; this.shown = [];
    const watch = () => { this._watch(); requestAnimationFrame(watch); };
    requestAnimationFrame(watch);
  }

  async reset() {
    this.spoken0 = performance.now(); this.seen = -1; this.shown = [];
    this.clock = new LiveClock(30);
    this.ended = false;
    this.ready = this.player.setBodies([{ label: this.label, body: this.bodyUrl }]);
    await this.ready;
    this.player.attachClock(this.clock);
    for (const d of ['shownMedianMs', 'shownP90Ms', 'gaps']) delete this.element.dataset[d];
    this.caption.textContent = '';
  }

  _text(k, v) { if (this.ui[k] && this.ui[k].textContent !== v) this.ui[k].textContent = v; }

  _buttons(live) {
    if (this.ui.record) this.ui.record.disabled = live;
    if (this.ui.stop) this.ui.stop.disabled = !live;
  }

  async start() {
    if (this.ws) return;
    this._buttons(true);
    this._text('status', 'starting the microphone');
    const mic = new LiveMic();
    try {
      await mic.open();
    } catch (e) {
      mic.close(); this._buttons(false);
      return this._text('status', `no microphone: ${e.message || e} (allow it for this page and press Record again)`);
    }
    const url = new URL(this.element.dataset.socket || 'gesturelsm/live', document.baseURI);
    url.protocol = url.protocol === 'https:' ? 'wss:' : 'ws:';
    const ws = new WebSocket(url); ws.binaryType = 'arraybuffer';
    this.ws = ws; this.mic = mic;
    ws.onmessage = (e) => this.push(e.data);
    ws.onclose = () => {
      mic.close();
      if (this.ws === ws) this.ws = null;
      this._buttons(false);
      if (!this.ended) this._text('status', 'the connection to the server closed');
    };
    ws.onerror = () => this._text('status', 'could not reach the live stream on the server');
    ws.onopen = async () => {
      ws.send(JSON.stringify({ sample_rate: mic.rate }));
      await this.reset();
      this.spoken0 = null;                          // set by the first block
      this._text('status', 'streaming');
      await mic.start((pcm) => {
        if (this.spoken0 === null) this.spoken0 = performance.now() - 1000 * SEND_S;
        if (ws.readyState === WebSocket.OPEN) ws.send(pcm.buffer);
      });
    };
  }

  stop() {
    if (this.mic) this.mic.close();
    if (this.ws && this.ws.readyState === WebSocket.OPEN) {
      this.ws.send(JSON.stringify({ end: true }));
      this._text('status', 'generating the rest of the speech');
    }
    if (this.ui.stop) this.ui.stop.disabled = true;
  }

  async push(json) {
    let d; try { d = JSON.parse(json); } catch (e) { return; }
    this.last = { audio_seconds: d.audio_seconds, frames: d.frames, at: performance.now() };   // for benchmarks
    if (!this.clock) await this.reset();           // frames from a stream whose start this page did not see
    await this.ready;
    const n = d.root ? d.root.length / 3 : 0;
    if (n && d.start === this.player.frames()) {   // contiguous with what is shown (chunks never overlap)
      const E = d.expressions && d.expressions.length ? d.expressions.length / n : 0;
      this.clock.arrived(d.start);
      this.player.appendFrames(0, Float32Array.from(d.rotations), Float32Array.from(d.root),
        E ? Float32Array.from(d.expressions) : null);
    } else if (n) this.element.dataset.gaps = String(Number(this.element.dataset.gaps || 0) + 1);
    if (d.median_latency_ms != null) {
      this._text('latency', String(Math.round(d.median_latency_ms)));
      this._text('stats', `p90 ${Math.round(d.p90_latency_ms)} ms · real-time factor ` +
        `${(d.real_time_factor || 0).toFixed(1)}x · ${d.frames} frames`);
    }
    if (d.status) this._text('status', d.status);
    if (d.status && d.status !== 'streaming') { this.ended = true; if (this.mic) this.mic.close(); }
  }

  _watch() {
    const f = this.player.shown;
    if (this.spoken0 === null || f <= this.seen) return;
    this.seen = f;
    this.shown.push(performance.now() - (this.spoken0 + (1000 * f) / 30));
    if (this.shown.length > 20000) this.shown.shift();
    const now = performance.now();
    if (now - (this.statsAt || 0) < 250) return;    // the page's layout: 4 times a second
    this.statsAt = now;
    const s = [...this.shown].sort((a, b) => a - b);
    const q = (p) => s[Math.min(s.length - 1, Math.floor(p * s.length))];
    this.element.dataset.shownMedianMs = String(Math.round(q(0.5)));
    this.element.dataset.shownP90Ms = String(Math.round(q(0.9)));
    this.caption.textContent = `on screen ${(q(0.5) / 1000).toFixed(2)} s after the speech (median; p90 ` +
      `${(q(0.9) / 1000).toFixed(2)} s), in this browser`;
  }
}

export function mountLive(element, box = document) {
  if (!element.__live) element.__live = new LiveFeed(element, element.dataset.preload, box);
  window.gesturelsmLive = element.__live;
  return element.__live;
}

window.GestureLSMPlayer = { MotionPlayer, mount, LiveClock, LiveFeed, LiveMic, mountLive };
