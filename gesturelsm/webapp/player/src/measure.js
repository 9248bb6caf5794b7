// Measurement hooks for the benchmarks (benchmarks/player_latency.py, benchmarks/live_browser.py), off by default.
// On with `?measure=1` in the page's address, or by setting `measure = true` on the page's player
// (window.gesturelsmPlayer) or on the live feed (window.gesturelsmPlayer.live). When on, the player sums the ms
// of each part of its draws into `prof` and `load()` writes its marks into the element's data-marks; the live
// feed stamps each message's meta with its arrival time (`live.last.at`). When off, none of this runs.

// Whether the page's address asks for measurement (?measure=1).
export function requested() {
  return typeof location !== 'undefined' && new URLSearchParams(location.search).get('measure') === '1';
}

// ms spent per part of the draws so far: pose = bones from the motion, render = three.js (skinning + raster),
// labels = label positions, dom = data-* attributes and state; draws = how many draws were summed.
export function drawProfile() {
  return { pose: 0, render: 0, labels: 0, dom: 0, draws: 0 };
}

// Add the ms since `t0` to `part` of `prof`; returns now, the start of the next part.
export function lap(prof, part, t0) {
  const now = performance.now();
  prof[part] += now - t0;
  return now;
}
