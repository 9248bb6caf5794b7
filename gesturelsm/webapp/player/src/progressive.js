// The page's payloads (gesturelsm/webapp/player/component.py `payload`): one request arrives in parts. The first
// payload of a request (a new `id`) names the speech and one slot per method; every later one is the same request
// with more of it done: a body entry gains `motion` (its motion file's URL) when the method finishes, or `error`
// when it failed. Each body joins the running clock the moment its motion is decoded (MotionPlayer.join: nothing
// restarts); the first one starts the speech from its beginning. On the visitor's character (payload.character) a
// method's frames come inside the payload (character.methods, there whenever its body has `motion`), and its
// motion file is drawn only if the character cannot be loaded.
// A body entry with `partial` holds the motion of a method still being made, its first windows as decoded so far
// (gesturelsm/serve/preview.py): the body joins on it and moves, and each later payload's longer motion (another
// file) replaces its frames on the same clock, until the entry without `partial` brings the finished motion, which
// replaces them for good (a file fetched late is dropped when a newer one of its slot was asked for since).
// A payload with `resume` (an edit or an undo: the same speech, another request folder) keeps the time on screen and
// play / pause: its first body starts the speech where the previous one was. A payload with `compare` (an edit) loads
// the motion before the edit for the A/B button once the edited body has joined.
// With measuring on (measure.js) the element's data-marks holds, in ms from the first payload: bodies (slots
// built), given (the first payload with a motion URL handed over), motion (first motion decoded), play (first body
// moving, the speech playing), all (every slot moving).
import { decodeMotion } from './motion_decoder.js';

function fetchRecord(url) {
  return fetch(url).then((r) => {
    if (!r.ok) throw new Error(`${url}: HTTP ${r.status}`);
    return r.arrayBuffer();
  }).then((buf) => decodeMotion(buf, url));
}

// A new request: the speech starts loading, the slots are built (the bodies ready at once join straight away).
function begin(p, payload) {
  const req = { id: payload.id, joined: new Set(), done: new Set(), failed: new Set(), urls: [],
    marks: p.measure ? { start: performance.now() } : null };
  const was = p.clock ? { t: p.clock.currentTime || 0, paused: p.clock.paused } : (p.request && p.request.resume);
  req.resume = payload.resume ? was || null : null;
  p.request = req;
  p.payload = payload;
  delete p.element.dataset.error; delete p.element.dataset.characterError;
  p.pause();
  p.records = []; p.compare = null; p._showCompare();     // no A/B until this request's edited body is in
  p.clock = null;                                    // no clock until a body moves: data-state stays loading
  p.audio.src = payload.audio || '';                 // the speech loads while the methods are generated
  const specs = payload.bodies.map((b) => ({ ...b, pending: true }));
  req.slots = p.setBodies(specs, payload.fps, payload.character).then((ok) => {
    if (ok && req.marks) req.marks.bodies = performance.now() - req.marks.start;
    return ok;
  });
  return req;
}

async function start(p, req) {
  p.audio.currentTime = req.resume ? req.resume.t : 0;
  p.attachClock(p.audio);
  if (!(req.resume && req.resume.paused)) await p.play();
  if (req.marks && p.measure) {
    req.marks.play = performance.now() - req.marks.start;
    p.marks = req.marks;
    p.element.dataset.marks = JSON.stringify(req.marks);
  }
}

function allIn(p, req) {
  if (!req.marks || !p.measure || req.done.size + req.failed.size < p.payload.bodies.length) return;
  req.marks.all = performance.now() - req.marks.start;
  p.element.dataset.marks = JSON.stringify(req.marks);
}

// Body i (moving) shows `record` from now on: its frames replaced on the same clock (a partial motion that grew, or
// the finished motion after it).
function replaceMotion(p, i, record) {
  p.records[i] = record;
  p.bodies[i].frames = 0;
  p.appendRecord(i, record, p.specs[i].motion);
  p.shown = -1; p.dirty = true;
}

// Body i of the request: its motion fetched and decoded (not on the character), then it joins, or, already moving
// on a partial motion, its frames are replaced by these.
async function arrive(p, req, payload, i) {
  const b = payload.bodies[i];
  const record = await fetchRecord(b.motion);              // drawn unless the character is on screen
  if (!(await req.slots) || p.request !== req || req.urls[i] !== b.motion) return;   // replaced since
  if (req.marks && req.marks.motion === undefined) req.marks.motion = performance.now() - req.marks.start;
  if (!b.partial) req.done.add(i);
  if (req.joined.has(i)) {
    replaceMotion(p, i, record);
    if (!b.partial) allIn(p, req);
    return;
  }
  p.join(i, record, payload.character);
  p.setRange(...(p.editRange || []));                      // the edit range drawn against the frames now in
  const first = req.joined.size === 0;
  req.joined.add(i);
  if (first) await start(p, req);
  if (payload.compare && payload.compare.index === i) await p._loadCompare(payload, p.generation);
  allIn(p, req);
}

export async function loadPayload(p, payload) {
  let req = p.request;
  if (!req || req.id !== payload.id || !payload.id) req = begin(p, payload);
  p.payload = payload;
  const pending = [];
  payload.bodies.forEach((b, i) => {
    if (req.failed.has(i) || (req.asked && req.asked.has(i)) || (b.motion && req.urls[i] === b.motion)) return;
    if (b.error) {
      req.failed.add(i);
      req.slots.then((ok) => { if (ok && p.request === req) { p.fail(i, b.error); allIn(p, req); } });
    } else if (b.motion) {
      if (req.marks && req.marks.given === undefined) req.marks.given = performance.now() - req.marks.start;
      if (!b.partial) (req.asked = req.asked || new Set()).add(i);   // the finished motion: nothing after it
      req.urls[i] = b.motion;
      pending.push(arrive(p, req, payload, i));
    }
  });
  try {
    await Promise.all(pending);
  } catch (e) {
    p.element.dataset.error = String(e.message || e);
    throw e;
  }
}
