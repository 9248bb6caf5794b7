"""The generator in streaming form: 16 kHz audio chunks in (any size), 30 fps motion chunks out.

Windows (t = 32 latents = 128 frames, seed s = 4 latents, as offline in generator/sampling.py): window i
*finalises* latents [st, st + c) with st = i c (1 <= c <= t - s; offline is c = t - s = 28) and runs as soon as the
audio reaches latent e = st + c + `lookahead`. It covers [e - t, e) (from latent 0 while e < t): it *ends* at the
newest audio, so the network sees real speech all through the window, as in training (windows anchored at st, with
silence after the look-ahead, lose the loudness following: tests/live/test_stream.py). Its latents before st are
already final: its first s are the seed, and the last `held` of them (all of them with held = 0) are kept fixed while
sampling (replacement inpainting, flows/base.py `inpainting`), so the new latents continue them and nothing final is
rewritten (the window's earlier latents are sampled afresh with the speech and dropped). So the motion of a moment
needs at most c + lookahead latents of later audio (4 frames = 133.3 ms per latent): with the defaults c = 3,
lookahead = 1 that is 0.53 s at worst, 0.33 s on average, plus compute; a player that plays at a steady 1x delay
must wait for the worst case (gesturelsm/webapp/player/src/live_clock.js `LiveClock`).

Why these defaults (figures and the commands that measure them: docs/BENCHMARKS.md, live mode): c = 3,
lookahead = 1, held = 4 puts the median delay from speech to its motion under half a second. Holding every final
latent of the window fixed, small commits extend the motion a few latents at a time from a long fixed past, which
carries its momentum more than the new speech's loudness, so they follow the loudness less (c = 3: +0.10 against
+0.13 at c = 5); holding only the last 4 (the seed's length, what offline windows continue from) lets the window's
earlier part follow its own speech again, and the new latents with it (+0.16). With lookahead 0 the decoder has no
latent right of a chunk, so it is given the chunk's last latent repeated (below). Under 0.3 s of delay needs
c / 2 + lookahead <= ~1.5 latents, and no such point keeps the motion's quality within 10 % of these defaults:
with lookahead 0 the motion follows the loudness about half as much (c = 2: +0.08 against +0.16), c = 1 raises the
hands less and needs a window's compute in 133 ms (docs/LIVE.md, "Delay against quality"). Streamed motion is
calmer than offline (every window start pulls the motion towards the mean, more so the shorter the commit); stronger
guidance pays most of it back, so the live default is CFG 6. With lookahead >= t - c each window starts at st, is
seeded with the previous window's latents there and cross-fades them exactly as offline: the windows, seeds, noise
draws and latents are the offline ones (same seed -> same noise sequence).

Audio features (features/audio.py) per window, from the audio of the window plus `context_s` seconds before it:
- envelope (max |y| over the next 1024 samples): exact wherever 1024 later samples have arrived; within 64 ms of
  the newest sample it is computed from what has arrived (as offline at the end of a file);
- onsets: librosa's detector normalises by the maximum over the audio it sees (offline: the whole file), so onsets
  are detected on the context + window span: nearly the offline onsets, not bit-identical (tests/live measure it).

Decoding: the RVQ-VAE decoder is convolutional with a wide receptive field (a latent moves frames up to ~22 latents
away, the far ones by little). Frames of the finalised latents are decoded with `decode_context` final latents on the
left and the window's own not-yet-final latents on the right (so no waiting); `decode_lag` > 0 instead waits for that
many final latents on the right. The next decode sees final values there and differs a little near the seam, so the
first `blend_frames` frames of each chunk fade (in feature space, cosine weights) from the previous decode of those
frames into the new one: no jump at seams and no extra latency. The previous decode has only 4 * lookahead frames past
the chunk; beyond them its last offset fades out (a fade over only those frames leaves seams rougher than the inside:
`benchmarks/live_latency.py --skip-paced` prints the seam jerk). With lookahead 0 the window has no latent right of the
span: the decoder is given the span's last latent repeated there (enough for `blend_frames`), so the chunk's last frames
have a right context and the next chunk has a decode to fade from (without it the jerk at seams was 6x the inside on a
held-out take). Root translation is integrated across chunks (motion/translation.py convention). Feet on the ground
(`grounding`, on by default): each emitted chunk is grounded causally before it leaves, by one `MotionStreamGrounder`
per stream (gesturelsm/grounding/motion_stream.py: contacts, plants, drift filter and blends carried across chunks), so
no frame waits for later speech and frames once emitted never change. Motion time is locked to audio time: frame f is
audio sample f * 16000 / 30, and the stream ends with exactly the offline frame count floor(N * 30 / 16000).
"""
from __future__ import annotations

import time
from collections import deque
from dataclasses import dataclass, field
from typing import Iterable, Iterator

import numpy as np
import torch

from ..constants import FPS, SAMPLE_RATE
from ..features.audio import audio_channels
from ..features.text import TEXT_DIM
from ..backends import FlowBackend
from ..errors import AudioError, InputError
from ..flows import make_method
from ..flows.base import inpainting
from ..generator.data import samples_for
from ..generator.sampling import decode_latents
from ..grounding.motion_stream import MotionStreamGrounder
from ..motion.regions import TRANS_OFFSET, join_regions
from ..motion.sequence import MotionSequence
from .config import LiveConfig


@dataclass
class MotionChunk:
    motion: MotionSequence         # frames [start, start + len) of the stream, 30 fps
    start: int                     # first frame index
    produced: float                # perf_counter() when it became available
    latencies: list[float] = field(default_factory=list)  # s, per audio chunk completed by it: produced - arrival
    audio_ahead_s: float = 0.0     # audio that had arrived beyond this chunk's last frame (algorithmic look-ahead)

    @property
    def stop(self) -> int:
        return self.start + self.motion.num_frames


class StreamingGenerator:
    """feed(chunk) -> motion chunks available now; finish() -> the rest. One stream per object (not thread-safe)."""

    def __init__(self, pipe, config: LiveConfig = LiveConfig()):
        backend = pipe.backends.get(config.method)
        if not isinstance(backend, FlowBackend):           # streaming reaches into our generator's windows
            raise InputError(f"live mode streams one of our loaded generators ({', '.join(pipe.generators) or 'none'});"
                             f" not {config.method}")
        self.model, self.tokenizers = backend.model, backend.tokenizers
        c = self.model.config
        self.t, self.s = c.window_latents, c.seed_latents
        config.check(self.t, self.s)
        self.cfg = config
        self.method = make_method(self.model.method)
        self.n_a = samples_for(4 * self.t)                             # samples per window
        self.gen = torch.Generator(device="cpu").manual_seed(int(config.seed))
        R, D = c.num_regions, c.latent_dim
        self.ramp = torch.arange(1, self.s + 1, dtype=torch.float32) / (self.s + 1)
        self.std = self.model.latent_std.cpu()[:, None, None]
        self.lat = torch.zeros(R, 0, D)        # scaled latents [lat0, lat0 + len): final < final_end, then provisional
        self.lat0 = 0
        self.final_end = 0                     # latents finalised so far
        self.window = 0                        # next window index
        self.audio = np.zeros(0, np.float32)   # samples [a0, a0 + len)
        self.a0 = 0
        self.n_in = 0                          # samples received
        self.emitted = 0                       # frames emitted
        self.xz = (0.0, 0.0)                   # root x, z of the last emitted frame
        self.arrivals: deque[tuple[int, float]] = deque()   # (end sample, arrival time) of unanswered chunks
        self.finished = False
        self.compute_s = 0.0
        self.tail = torch.zeros(0, 1)          # (<= blend_frames, 433) last decode of the frames after the emitted ones
        self.grounder = MotionStreamGrounder() if config.grounding else None

    # ---- input -----------------------------------------------------------------------------------------------
    def feed(self, chunk: np.ndarray, arrival: float | None = None) -> list[MotionChunk]:
        """chunk: (n,) float32 16 kHz mono; arrival: perf_counter() time it arrived (default: now)."""
        if self.finished:
            raise RuntimeError("this stream has finished; start a new one")
        y = np.asarray(chunk, np.float32).reshape(-1)
        if not np.isfinite(y).all():
            raise AudioError("the audio chunk contains invalid samples (NaN or infinity)")
        self.audio = np.concatenate([self.audio, y])
        self.n_in += len(y)
        self.arrivals.append((self.n_in, time.perf_counter() if arrival is None else arrival))
        out = []
        while self.n_in >= samples_for(4 * ((self.window + 1) * self.cfg.commit + self.cfg.lookahead)):
            out += self._run_window(end=None)
        return out

    def finish(self) -> list[MotionChunk]:
        """The audio has ended: generate and emit everything up to the last whole frame."""
        if self.finished:
            return []
        self.finished = True
        T = self.n_in * FPS // SAMPLE_RATE
        keep = samples_for(T) - self.a0                                 # offline trims the audio to T frames
        self.audio, self.n_in = self.audio[:max(keep, 0)], samples_for(T)
        L = -(-T // 4)
        out = []
        while self.window == 0 or self._span(self.window - 1)[0] + self.t < L:
            out += self._run_window(end=L)
        if self.emitted < T:
            out += self._emit(L, T, final_all=True)
        return out

    def stream(self, chunks: Iterable[np.ndarray]) -> Iterator[MotionChunk]:
        """The Python API: iterate over audio chunks, get motion chunks as soon as they exist."""
        for ch in chunks:
            yield from self.feed(ch)
        yield from self.finish()

    # ---- one window --------------------------------------------------------------------------------------
    def _channels(self, a: int, b: int, avail: int) -> torch.Tensor:
        """(2, b - a) channels of samples [a, b) from the audio before sample `avail` (zeros past it)."""
        lo = max(self.a0, a - int(self.cfg.context_s * SAMPLE_RATE))
        hi = min(avail, b)
        ch = np.zeros((2, b - a), np.float32)
        if hi > a:
            y = self.audio[lo - self.a0:hi - self.a0]
            ch[:, :hi - a] = audio_channels(y)[:, a - lo:]
        return torch.from_numpy(ch)

    def _span(self, window: int) -> tuple[int, int, int]:
        """(w0, st, e) of a window: it finalises latents from st = window * commit, waits for audio up to latent
        e = st + commit + lookahead, and covers [w0, w0 + t), ending at e (real audio all through) once e >= t."""
        st = window * self.cfg.commit
        e = st + self.cfg.commit + self.cfg.lookahead
        return min(st, max(0, e - self.t)), st, e

    @torch.no_grad()
    def _run_window(self, end: int | None) -> list[MotionChunk]:
        t0 = time.perf_counter()
        m, t, s = self.model, self.t, self.s
        w0, st, e = self._span(self.window)
        a = samples_for(4 * w0)
        # the window sees exactly the audio its trigger asked for (not what else has arrived): results do not
        # depend on how the audio was chunked
        avail = self.n_in if end is not None else samples_for(4 * e)
        ch = self._channels(a, a + self.n_a, avail)[None]                                 # (1, 2, n_a)
        w, hw = torch.zeros(1, 4 * t, TEXT_DIM), torch.zeros(1, 4 * t, dtype=torch.bool)
        cond = m.speech(ch, w, hw, torch.zeros(1, dtype=torch.bool))
        R, D = self.lat.shape[0], self.lat.shape[2]
        noise = torch.randn(1, R, t, D, generator=self.gen)
        k0, k = w0 - self.lat0, st - self.lat0
        seed = m.neutral_seed[None] if w0 == 0 else self.lat[:, k0:k0 + s][None]
        f = m.bind(cond, seed)
        if st > w0:         # latents [w0, st) are final: generate the rest of the window consistent with them
            known = torch.zeros(1, R, t, D)
            known[0, :, :st - w0] = self.lat[:, k0:k]
            lo = 0 if self.cfg.held <= 0 else max(0, st - w0 - self.cfg.held)
            mask = ((torch.arange(t) < st - w0) & (torch.arange(t) >= lo))[None, None, :, None]
            f = inpainting(f, self.method, known, mask, noise)
        x = self.method.sample(f, noise, self.cfg.steps, self.cfg.cfg)[0][:, st - w0:]        # (R, w0 + t - st, D)
        if self.window > 0 and st == w0:  # seeded by the previous window's provisional latents: cross-fade (offline)
            ov = self.lat[:, k:k + s]
            x = torch.cat([ov * (1 - self.ramp)[None, :, None] + x[:, :s] * self.ramp[None, :, None], x[:, s:]], 1)
        self.lat = torch.cat([self.lat[:, :k], x], 1)
        self.window += 1
        self.final_end = st + self.cfg.commit
        self.compute_s += time.perf_counter() - t0
        if end is not None and w0 + t >= end:
            self.final_end = end
            return []                                            # finish() emits the rest with everything final
        return self._emit(self.final_end - self.cfg.decode_lag, None)

    # ---- decoding and output ----------------------------------------------------------------------------
    def _emit(self, upto: int, T: int | None, final_all: bool = False) -> list[MotionChunk]:
        """Decode and emit frames up to latent `upto` (or frame T at the end)."""
        t0 = time.perf_counter()
        e = self.emitted // 4
        stop = 4 * upto if T is None else T
        if stop <= self.emitted:
            return []
        lo = max(0, e - self.cfg.decode_context)
        hi = self.lat0 + self.lat.shape[1] if not final_all else -(-T // 4)
        z = self.lat[:, lo - self.lat0:hi - self.lat0] * self.std                          # (R, n, D) un-scaled
        if T is None and 4 * hi <= stop:   # no latent right of the span (look-ahead 0): its last one, repeated
            z = torch.cat([z, z[:, -1:].expand(-1, -(-self.cfg.blend_frames // 4), -1)], 1)
        parts = decode_latents(self.tokenizers, z, 4 * z.shape[1])
        every = join_regions({k: v.cpu() for k, v in parts.items()})                        # (4 (hi - lo), 433)
        feats = every[self.emitted - 4 * lo:stop - 4 * lo].clone()
        if len(self.tail) and len(feats):        # fade from the previous decode of these frames into this one
            n = min(self.cfg.blend_frames, len(feats))
            w = 0.5 - 0.5 * torch.cos(torch.pi * torch.arange(1, n + 1, dtype=torch.float32) / (n + 1))[:, None]
            i = torch.arange(n).clamp(max=len(self.tail) - 1)   # past the old decode: its last offset, fading out
            feats[:n] = feats[:n] + (1 - w) * (self.tail[i] - feats[i])
        self.tail = every[stop - 4 * lo:stop - 4 * lo + self.cfg.blend_frames].clone()
        dx, dz = float(feats[0, TRANS_OFFSET]), float(feats[0, TRANS_OFFSET + 2])
        start_xz = (0.0, 0.0) if self.emitted == 0 else (self.xz[0] + dx, self.xz[1] + dz)
        motion = MotionSequence.from_features(feats, start_xz=start_xz)
        self.xz = (float(motion.trans[-1, 0]), float(motion.trans[-1, 2]))
        if self.grounder is not None:            # the decoder's root path continues above; the frames out are grounded
            motion = self.grounder.push(motion).motion
        now = time.perf_counter()
        chunk = MotionChunk(motion, self.emitted, now, audio_ahead_s=(self.n_in - samples_for(stop)) / SAMPLE_RATE)
        while self.arrivals and (self.arrivals[0][0] <= samples_for(stop) or T is not None):
            chunk.latencies.append(now - self.arrivals.popleft()[1])
        self.emitted = stop
        self._trim()
        self.compute_s += time.perf_counter() - t0
        return [chunk]

    def _trim(self) -> None:
        """Drop latents and audio no later window or decode needs (memory stays flat on endless streams)."""
        w0 = self._span(self.window)[0]                           # the next window's first latent
        keep_lat = min(w0, self.emitted // 4 - self.cfg.decode_context)
        if keep_lat > self.lat0:
            self.lat = self.lat[:, keep_lat - self.lat0:]
            self.lat0 = keep_lat
        keep_a = samples_for(4 * w0) - int(self.cfg.context_s * SAMPLE_RATE)
        if keep_a > self.a0:
            self.audio = self.audio[keep_a - self.a0:]
            self.a0 = keep_a
