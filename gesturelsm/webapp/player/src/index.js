// The bundle's entry (esbuild -> ../dist/player.js): mounts the page's players and publishes the one global API,
//   window.gesturelsmPlayer        the page's MotionPlayer (#motion-player; player.js documents its methods)
//   window.gesturelsmPlayer.live   the Live tab's LiveFeed (#live-player; live_feed.js), null without one
// The page imports this module and calls mount(element) / mountLive(element, box) (../component.py,
// gesturelsm/webapp/live.py) and chooseLiveCharacter(spec) when the visitor chooses or clears a character; the other
// exports are for tools and tests that import the bundle.
import { LiveFeed } from './live_feed.js';
import { MotionPlayer } from './player.js';

export { Body } from './body.js';
export { LiveClock } from './live_clock.js';
export { LiveMic } from './microphone.js';
export { decodeMotion } from './motion_decoder.js';
export { LiveFeed, MotionPlayer };

let liveFeed = null;            // the page's live feed, whichever of the two players mounts first
let liveCharacter = null;       // the page session's character for the live feed (gesturelsm/live/characters.py)

// One player per element, created on first use; the page calls gesturelsmPlayer.load(payload).
export function mount(element) {
  if (!element.__player) {
    element.__player = new MotionPlayer(element);
    const done = () => { element.dataset.ready = '1'; };
    if (element.dataset.preload) element.__player.preload(element.dataset.preload).then(done, done);
    else done();
  }
  element.__player.live = liveFeed;
  window.gesturelsmPlayer = element.__player;
  return element.__player;
}

// The Live tab's player (one per element): its body is the element's data-preload, its buttons and meter are the
// #live-* elements inside `box`.
export function mountLive(element, box = document) {
  if (!element.__live) element.__live = new LiveFeed(element, element.dataset.preload, box);
  liveFeed = element.__live;
  if (liveCharacter) liveFeed.useCharacter(liveCharacter);     // the constructor already shows the mannequin
  if (window.gesturelsmPlayer) window.gesturelsmPlayer.live = liveFeed;
  return liveFeed;
}

// The Character upload's event (gesturelsm/webapp/live.py character_js): the live feed streams on this character from
// its next Record on ({token, name, url, key}; null: the mannequin), whether or not the Live tab is mounted yet.
export function chooseLiveCharacter(spec) {
  liveCharacter = spec && spec.token ? spec : null;
  if (liveFeed) liveFeed.useCharacter(liveCharacter);
}
