// The microphone of the Live tab: an AudioWorklet (mic_worklet.js, bundled as text) taps it (at 16 kHz where the
// browser resamples for us, as Chromium and Firefox do) and hands over int16 PCM blocks of SEND_S seconds as they
// are captured.
import TAP from './mic_worklet.js' with { type: 'text' };

export const SEND_S = 0.05;

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
