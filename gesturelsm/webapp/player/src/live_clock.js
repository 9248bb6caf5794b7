// The clock of the live player: motion arrives in chunks while the visitor speaks, and frame f is shown at
// f / fps + delay (seconds of performance.now()), where delay is the largest lateness (browser arrival time - first
// frame / fps) of the last LATE_KEEP chunks. Playback runs at 1x, keeps one steady delay behind the voice, and never
// goes backwards (when the delay grows it holds the frame; when it shrinks it skips ahead). A MotionPlayer takes it
// through attachClock like the speech's <audio> element (currentTime, paused, play(), pause()).
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
