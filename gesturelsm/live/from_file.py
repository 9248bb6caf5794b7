"""A speech file fed to the live generator as if it came from a microphone, chunk by chunk (`gesturelsm live`, the
live benchmarks): the motion chunks, each audio chunk's latency, and the time the work took."""
from __future__ import annotations

import time
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..constants import SAMPLE_RATE
from ..motion.sequence import MotionSequence
from .stream import LiveConfig, MotionChunk, StreamingGenerator

if TYPE_CHECKING:
    from ..export.engine_stream import EngineStream


@dataclass
class LiveRun:
    chunks: list[MotionChunk]
    latencies: np.ndarray          # (n_audio_chunks,) s: motion available - chunk arrival
    audio_seconds: float
    wall_seconds: float
    compute_seconds: float

    @property
    def real_time_factor(self) -> float:
        """Audio seconds per second of generation work (> 1: faster than real time)."""
        return self.audio_seconds / max(self.compute_seconds, 1e-9)

    def motion(self):
        ms = [c.motion for c in self.chunks]
        return MotionSequence(np.concatenate([m.poses for m in ms]), np.concatenate([m.trans for m in ms]),
                              np.concatenate([m.expressions for m in ms]))


def run_file(pipe, audio: np.ndarray, config: LiveConfig = LiveConfig(), chunk_ms: float = 200.0,
             realtime: bool = False, engines: EngineStream | None = None) -> LiveRun:
    """Feed `audio` (N,) 16 kHz in chunks of `chunk_ms`; with `realtime` chunk k arrives (and is fed) when its last
    sample would have been spoken, else all as fast as possible (then latency is compute only). `engines`: a
    started EngineStream each committed chunk's frames are pushed to as they come (sent on its steady clock)."""
    n = max(1, int(round(chunk_ms * SAMPLE_RATE / 1000)))
    gen = StreamingGenerator(pipe, config)
    out: list[MotionChunk] = []
    t0 = time.perf_counter()
    for a in range(0, len(audio), n):
        chunk = audio[a:a + n]
        arrival = None
        if realtime:
            arrival = t0 + (a + len(chunk)) / SAMPLE_RATE
            time.sleep(max(0.0, arrival - time.perf_counter()))
        new = gen.feed(chunk, arrival)
        out += new
        for c in new if engines is not None else ():
            engines.push(c.motion)
    last = gen.finish()
    out += last
    for c in last if engines is not None else ():
        engines.push(c.motion)
    lat = np.array([x for c in out for x in c.latencies])
    return LiveRun(out, lat, len(audio) / SAMPLE_RATE, time.perf_counter() - t0, gen.compute_s)
