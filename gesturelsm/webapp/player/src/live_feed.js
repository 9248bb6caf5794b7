// The live player of the Live tab (gesturelsm/webapp/live.py): a MotionPlayer with one body, on a LiveClock, fed the motion
// records (motion_decoder.js) the server pushes over the app's WebSocket (protocol in webapp/live_socket.py).
// start() opens the microphone (microphone.js) and the socket (element data-socket), streams the speech and plays
// the motion that comes back; stop() sends the end (the server generates the rest, then closes). push(buffer)
// appends the frames a message carries; reset() starts a new stream; `last` is the meta of the latest message
// (frames so far, audio seconds received, latencies, status).
// The visitor's character (the page's Character upload): useCharacter(spec) (index.js chooseLiveCharacter; spec =
// {token, name, url, key, bones, nodes, align, scale, head, morphs} or null) fetches and parses it once (before the
// first stream it stands there at rest), and from the next start() on the hello names its token; the server answers
// with the character's bones (a frames-less first message, meta.character) and every record then carries the frames
// on the character (motion_decoder.js character section), drawn with character.js' applyFrame, and its face's morph
// weights when its VRM binds visemes or blink (meta.character.morphs); the element carries data-character (the file
// name) while it is shown. A character the server no longer holds, or the browser cannot load, leaves the mannequin
// with the reason in data-character-error.
// The checkbox #live-grounding (feet on the ground, on by default) goes with the hello: the server grounds the stream
// causally, chunk by chunk, or not; it cannot change during a stream.
// The meter: #live-latency = the server's median (ms) from a block's arrival to its motion being ready,
// #live-stats = p90 and real-time factor, #live-status. It also measures the latency the visitor sees: for every
// newly drawn frame f, now - (capture of the first block - SEND_S + f / fps), i.e. from the moment the speech of
// that frame was spoken to the moment its motion is on screen (element data-shown-median-ms and data-shown-p90-ms,
// and the caption under the body).
import { fetchCharacter } from './character.js';
import { el } from './dom.js';
import { LiveClock } from './live_clock.js';
import { LiveMic, SEND_S } from './microphone.js';
import { decodeMotion } from './motion_decoder.js';
import { MotionPlayer } from './player.js';

export class LiveFeed {
  constructor(element, bodyUrl, box = document, label = 'live') {
    this.player = new MotionPlayer(element);
    this.element = element; this.bodyUrl = bodyUrl; this.label = label;
    element.classList.add('mp-streaming');             // player.css: no play button or seek bar
    this.caption = el('span', { class: 'mp-live' }, element.querySelector('.mp-bar'));
    this.ui = Object.fromEntries(['record', 'stop', 'latency', 'stats', 'status', 'grounding'].map((k) => [k, box.querySelector(`#live-${k}`)]));
    if (this.ui.record) this.ui.record.addEventListener('click', () => this.start());
    if (this.ui.stop) this.ui.stop.addEventListener('click', () => this.stop());
    this.ready = this.player.setBodies([{ label, body: bodyUrl }]).then(() => {   // the body at rest until a stream
      this.player.standIdle();
      element.dataset.ready = '1';
    });
    this.spoken0 = null; this.seen = -1; this.shown = []; this.last = null;
    this.chosen = null; this.answer = null;
    const watch = () => { this._watch(); requestAnimationFrame(watch); };
    requestAnimationFrame(watch);
  }

  get measure() { return this.player.measure; }    // measure.js: also stamps each message's meta (last.at)
  set measure(on) { this.player.measure = on; }

  // The character the next stream uses (null: the mannequin); parsed now so that Record does not wait for it, and
  // shown at rest before the first stream (the spec has its bones, axes and scale: live/characters.py
  // `LiveCharacters.choose`).
  useCharacter(spec) {
    this.chosen = spec && spec.token ? spec : null;
    if (this.chosen) fetchCharacter(this.chosen).catch(() => {});   // a failure shows when a stream uses it
    if (this.ws || this.clock) return;                              // a stream is on screen: it stays
    const rest = this.chosen && this.chosen.nodes ? this.chosen : null;
    this.ready = this.player.setBodies([{ label: this.label, body: this.bodyUrl, method: 'live' }], 30, rest)
      .then(() => this.player.standIdle());
  }

  async reset(character = null) {
    this.spoken0 = performance.now(); this.seen = -1; this.shown = [];
    this.clock = new LiveClock(30);
    this.ended = false;
    this.ready = this.player.setBodies([{ label: this.label, body: this.bodyUrl, method: 'live' }], 30, character);
    await this.ready;
    this.player.attachClock(this.clock);
    for (const d of ['shownMedianMs', 'shownP90Ms', 'gaps']) delete this.element.dataset[d];
    this.caption.textContent = '';
  }

  _text(k, v) { if (this.ui[k] && this.ui[k].textContent !== v) this.ui[k].textContent = v; }

  _buttons(live) {
    if (this.ui.record) this.ui.record.disabled = live;
    if (this.ui.grounding) this.ui.grounding.disabled = live;    // a stream keeps the choice it started with
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
      if (this.answer) this.answer(null);
      if (this.ws === ws) this.ws = null;
      this._buttons(false);
      if (!this.ended) this._text('status', 'the connection to the server closed');
    };
    ws.onerror = () => this._text('status', 'could not reach the live stream on the server');
    const chosen = this.chosen;
    delete this.element.dataset.characterError;
    ws.onopen = async () => {
      const grounding = this.ui.grounding ? this.ui.grounding.checked : true;   // #live-grounding: feet on the ground
      ws.send(JSON.stringify(chosen ? { sample_rate: mic.rate, character: chosen.token, grounding }
        : { sample_rate: mic.rate, grounding }));
      // with a character: the server's first message says which bones it streams (or why it cannot)
      const spec = chosen ? await new Promise((resolve) => {
        this.answer = resolve;
        setTimeout(() => resolve(null), 10000);
      }) : null;
      this.answer = null;
      if (ws.readyState !== WebSocket.OPEN) return;
      await this.reset(spec);
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

  async push(buffer) {
    let rec;
    try {
      rec = decodeMotion(buffer, 'live message');
    } catch (e) {
      return this._text('status', e.message);
    }
    const d = rec.meta;
    if (!rec.frames && (d.character || d.character_error)) {     // the stream's character (its first message)
      if (d.character_error) this.element.dataset.characterError = d.character_error;
      if (this.answer) this.answer(d.character || null);
      return;
    }
    this.last = d;
    if (this.measure) d.at = performance.now();
    if (!this.clock) await this.reset();           // frames from a stream whose start this page did not see
    await this.ready;
    if (rec.frames && rec.start === this.player.frames()) {   // contiguous with what is shown (chunks never overlap)
      try {
        this.player.appendRecord(0, rec, 'live message');
      } catch (e) {
        return this._text('status', e.message);
      }
      this.clock.arrived(rec.start);
    } else if (rec.frames) this.element.dataset.gaps = String(Number(this.element.dataset.gaps || 0) + 1);
    if (d.median_latency_ms != null) {
      this._text('latency', String(Math.round(d.median_latency_ms)));
      this._text('stats', `p90 ${Math.round(d.p90_latency_ms)} ms · real-time factor ` +
        `${(d.real_time_factor || 0).toFixed(1)}x · ${d.frames} frames`);
    }
    if (d.status) this._text('status', d.status);
    if (d.status && d.status !== 'streaming') {
      this.ended = true;
      if (this.mic) this.mic.close();
      if (this.answer) this.answer(null);           // refused before naming the character (busy)
    }
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
