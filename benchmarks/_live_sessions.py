"""Live sessions at once, as the server runs them (benchmarks/live_latency.py --streams N)."""
from __future__ import annotations

import time

import numpy as np
from _harness import Rows, Stopwatch


def simultaneous(pipe, audio: np.ndarray, cfg, streams: int, chunk_ms: float) -> list[dict]:
    """`streams` live sessions at once, as the server runs them (gesturelsm/live/session.py: a worker thread each),
    every one fed the same audio at the pace of speech; per session its latencies (the session's own, from each
    chunk's arrival), real-time factor and how far behind the audio it ended."""
    from gesturelsm.constants import SAMPLE_RATE
    from gesturelsm.live.session import LiveManager

    n = int(round(chunk_ms * SAMPLE_RATE / 1000))
    manager = LiveManager(pipe, max_sessions=streams, config=cfg)
    sessions = [manager.open() for _ in range(streams)]
    with Stopwatch() as clock:
        for a in range(0, len(audio), n):
            time.sleep(max(0.0, (a + n) / SAMPLE_RATE - clock.elapsed))
            for s in sessions:
                s.feed(audio[a:a + n])
    out = []
    time.sleep(0.5)                                              # the last window's compute
    for s in sessions:
        st, g = s.stats(), s.gen
        lat = np.array(s.latencies)
        out.append({"lat": lat, "rtf": st["real_time_factor"], "behind_frames": g.n_in * 30 / SAMPLE_RATE - g.emitted,
                    "dropped": st["dropped_chunks"], "error": st["error"]})
        s.stop()
    return out



def simultaneous_table(rows: list[dict], seconds: float, chunk_ms: float) -> Rows:
    """The sessions' table (printed, and returned for a JSON copy)."""
    table = Rows([f"{len(rows)} live sessions at once ({seconds:.0f} s each, {chunk_ms:.0f} ms chunks)",
                  "latency median / p90 (s)", "median, last quarter (s)", "real-time factor",
                  "frames behind at the end", "dropped"])
    for i, r in enumerate(rows):
        lat = r["lat"]
        table.add(f"session {i + 1}{' (' + r['error'] + ')' if r['error'] else ''}",
                  f"{np.median(lat):.3f} / {np.percentile(lat, 90):.3f}", f"{np.median(lat[3 * len(lat) // 4:]):.3f}",
                  f"{r['rtf']:.2f}", f"{r['behind_frames']:.0f}", r["dropped"])
    print(table.markdown())
    print()
    return table
