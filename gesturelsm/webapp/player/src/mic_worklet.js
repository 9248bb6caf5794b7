// The AudioWorklet processor of the Live tab's microphone (microphone.js loads this file's text as a module of
// the AudioContext; it runs in the audio rendering thread, not in the page): collects the microphone's samples
// into blocks of processorOptions.n and posts each full block (a Float32Array, transferred) to the page.
class Tap extends AudioWorkletProcessor {
  constructor(o) { super(); this.n = o.processorOptions.n; this.b = new Float32Array(this.n); this.k = 0; }

  process(inputs) {
    const x = inputs[0] && inputs[0][0];
    if (x) {
      for (let i = 0; i < x.length; i++) {
        this.b[this.k++] = x[i];
        if (this.k === this.n) { this.port.postMessage(this.b, [this.b.buffer]); this.b = new Float32Array(this.n); this.k = 0; }
      }
    }
    return true;
  }
}

registerProcessor('gesturelsm-tap', Tap);
