"""The rater's page: plain HTML and JavaScript, no build step, served as is by server.py.

Element contracts (tests and tools rely on them): `#trial` with `data-trial` (index) and `data-kind`
(`pair` / `rating`); videos `#video-left` and `#video-right`; choice buttons `#prefer-left`, `#prefer-right`,
`#prefer-none`, enabled once both videos have played to the end; `#progress` with text `k / n` (k trials
answered of n); `#done` holding the completion code; `#error` showing any refusal from the server. Rating
trials show one video (`#video-left`), a 1-5 radio group per scale and `#submit-rating`.
The left video plays first and the right one follows when it ends; either can be replayed with its controls.
"""

PAGE = r"""<!doctype html>
<html lang="en"><head><meta charset="utf-8"><meta name="viewport" content="width=device-width,initial-scale=1">
<meta name="referrer" content="no-referrer"><title>Gesture study</title>
<style>
body{font-family:system-ui,sans-serif;max-width:1000px;margin:.5em auto;padding:0 1em;color:#222}
header{display:flex;justify-content:space-between;align-items:baseline}
h1{font-size:1.5em;margin:.4em 0}
#progress{font-variant-numeric:tabular-nums;color:#555}
.videos{display:flex;gap:1em;justify-content:center}
.videos figure{margin:0;text-align:center;flex:1}
video{width:100%;max-width:400px;background:#000;border-radius:6px}
.choices{display:flex;gap:1em;justify-content:center;margin:1.2em 0}
button{font-size:1.05em;padding:.6em 1.4em;border-radius:6px;border:1px solid #888;background:#f4f4f4;cursor:pointer}
button:disabled{opacity:.45;cursor:default}
#error{color:#b00020;min-height:1.4em;text-align:center}
.hint{color:#666;text-align:center}
.scale{margin:.6em 0;text-align:center}
[hidden]{display:none!important}
</style></head>
<body>
<header><h1>Gesture study</h1><span id="progress">0 / 0</span></header>
<main id="trial" data-trial="" data-kind="">
  <p id="question" class="hint">Watch both videos with sound. Which character's gestures look more natural and
  fit the speech better?</p>
  <div class="videos">
    <figure><video id="video-left" controls playsinline preload="auto"></video><figcaption>Left</figcaption></figure>
    <figure id="right-figure"><video id="video-right" controls playsinline preload="auto"></video>
      <figcaption>Right</figcaption></figure>
  </div>
  <div id="pair-choices" class="choices">
    <button id="prefer-left" disabled>Left is better</button>
    <button id="prefer-none" disabled>No preference</button>
    <button id="prefer-right" disabled>Right is better</button>
  </div>
  <form id="rating-form" hidden><div id="scales"></div>
    <div class="choices"><button id="submit-rating" type="submit" disabled>Next</button></div></form>
  <p class="hint" id="wait">The buttons unlock once both videos have played to the end.</p>
</main>
<section id="finished" hidden><h2>Thank you!</h2><p>Your completion code:</p>
  <p><code id="done" style="font-size:1.6em"></code></p></section>
<p id="error" role="alert"></p>
<script>
"use strict";
const token = decodeURIComponent(location.pathname.split("/")[2] || "");
const $ = (id) => document.getElementById(id);
const api = (path) => `/api/${encodeURIComponent(token)}/${path}`;
let session = null, current = null, ended = {}, busy = false;

async function call(path, body) {
  const r = await fetch(api(path), {method: "POST", headers: {"Content-Type": "application/json"},
                                    body: JSON.stringify(body || {})});
  let data = {};
  try { data = await r.json(); } catch (e) { data = {error: `the server answered ${r.status}`}; }
  if (!r.ok) throw new Error(data.error || `the server answered ${r.status}`);
  return data;
}

function needed() { return current && current.kind === "rating" ? ["left"] : ["left", "right"]; }
function allPlayed() { return needed().every((s) => ended[s]); }
function ratingsChosen() {
  return current.scales.every((s) => document.querySelector(`input[name="${s.name}"]:checked`));
}
function unlock() {
  const ok = !busy && current && allPlayed();
  for (const id of ["prefer-left", "prefer-right", "prefer-none"]) $(id).disabled = !ok;
  $("submit-rating").disabled = !(ok && current.kind === "rating" && ratingsChosen());
  $("wait").hidden = allPlayed();
}

function show(state) {
  $("progress").textContent = `${state.k} / ${state.n}`;
  if (state.code) {
    $("trial").hidden = true; $("finished").hidden = false; $("done").textContent = state.code;
    return;
  }
  current = state.trial; ended = {};
  const t = $("trial"), rating = current.kind === "rating";
  t.dataset.trial = String(current.index); t.dataset.kind = current.kind;
  $("pair-choices").hidden = rating; $("rating-form").hidden = !rating; $("right-figure").hidden = rating;
  $("question").textContent = rating ? "Watch the video with sound, then rate it on each scale."
    : current.question
      || "Watch both videos with sound. Which character's gestures look more natural and fit the speech better?";
  if (rating) {
    $("scales").innerHTML = "";
    for (const s of current.scales) {
      const div = document.createElement("div"); div.className = "scale";
      div.append(document.createTextNode(s.question), document.createElement("br"));
      for (let v = 1; v <= 5; v++) {
        const label = document.createElement("label"), input = document.createElement("input");
        input.type = "radio"; input.name = s.name; input.value = String(v); input.onchange = unlock;
        label.append(input, ` ${v} `); div.append(label);
      }
      $("scales").append(div);
    }
  }
  for (const side of ["left", "right"]) {
    const v = $(`video-${side}`);
    v.pause();
    if (side === "right" && rating) { v.removeAttribute("src"); v.load(); continue; }
    v.src = api(`video/${current.index}/${side}`);
    v.load();
  }
  $("video-left").play().catch(() => {});   // autoplay may need a click first; the controls are there
  unlock();
}

for (const side of ["left", "right"]) {
  $(`video-${side}`).addEventListener("ended", () => {
    ended[side] = true;
    if (side === "left" && !ended.right && current && current.kind === "pair") $("video-right").play().catch(() => {});
    unlock();
  });
}

async function submit(extra) {
  if (busy || !current) return;
  busy = true; unlock(); $("error").textContent = "";
  try {
    show(await call("answer", Object.assign({session, trial: current.index, played: allPlayed()}, extra)));
  } catch (e) {
    $("error").textContent = e.message;
  } finally { busy = false; unlock(); }
}
$("prefer-left").onclick = () => submit({choice: "left"});
$("prefer-right").onclick = () => submit({choice: "right"});
$("prefer-none").onclick = () => submit({choice: "none"});
$("rating-form").onsubmit = (ev) => {
  ev.preventDefault();
  const ratings = {};
  for (const s of current.scales) {
    ratings[s.name] = Number(document.querySelector(`input[name="${s.name}"]:checked`).value);
  }
  submit({ratings});
};

call("open").then((state) => { session = state.session; show(state); })
  .catch((e) => { $("error").textContent = e.message; $("trial").hidden = true; });
</script>
</body></html>
"""
