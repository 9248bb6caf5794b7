"""Live mode on this machine: latency, CPU share, memory, drift, and streamed vs offline quality.

    .venv/bin/python benchmarks/live_latency.py                       # 60 s paced run + quality on two takes
    .venv/bin/python benchmarks/live_latency.py --seconds 600         # 10 minutes (the real take looped)
    .venv/bin/python benchmarks/live_latency.py --skip-quality --threads 2
    .venv/bin/python benchmarks/live_latency.py --skip-quality --character avatar.vrm   # also on a character
    .venv/bin/python benchmarks/live_latency.py --skip-quality --grounding on off      # latency with and without
    .venv/bin/python benchmarks/live_latency.py --skip-paced --skip-quality --feet     # feet of streamed takes
    .venv/bin/python benchmarks/live_latency.py --skip-quality --chunk-ms 50 --streams 2   # + two sessions at once
    .venv/bin/python benchmarks/live_latency.py --before none --skip-paced --skip-quality \
        --sweep 3/1 3/0 2/0 2/1 1/1 --sweep-seeds 2 --sweep-seconds 30 --sweep-jobs 2   # delay against quality

Sweep (--sweep C/L ...): the curve of delay against quality over commit x look-ahead. Each point (the first is the
reference, e.g. the default 3/1) streams the two held-out takes (their first --sweep-seconds) x --sweep-seeds seeds,
the points interleaved stream by stream, in --block-ms blocks (the page's 50 ms) on a virtual clock of speech: block
k arrives when its last sample would have been spoken, the generator works from then (or when it finished the
previous block) for as long as its work took, so a window that overruns delays the next ones as in a paced run. The
work is counted in this thread's CPU time (what it needs of a core when no other work shares it) and, beside, in wall
time (on a loaded machine that adds the time other processes held the cores). Table: delay median / p90, raised
share, p95 wrist height, loudness following (mean and standard error over the streams), jerk at seams over inside,
each vs the reference in %, and the point with the lowest median delay whose raised share, wrist height and loudness
following are each at least 90 % of the reference's (seams at most 1.1x the reference's or the inside's).

Before / after: every run streams the live setting main shipped before (`--before main`, BEFORE below: commit 5,
look-ahead 1, all final latents held) beside the one measured (LiveConfig's defaults, or --commit ...), in the same
paced run and through the same quality tables; `--before key=value,...` compares another setting, `--before none`
measures one. --streams N: N live sessions at once (gesturelsm/live/session.py, a worker thread each, as the Live
tab runs them), each fed the take at the pace of speech: each one's latency (also in its last quarter: no drift),
real-time factor and frames behind at the end.

Paced run: a real take (../shared) looped to --seconds, fed in --chunk-ms chunks at the pace of speech (chunk k
arrives when its last sample would have been spoken; the page's microphone sends 50 ms). Latency of a chunk = when
the motion of all its frames is available - its arrival. CPU share = process CPU time / wall time (1.0 = one core busy).
Memory: resident set size sampled each chunk (first minute vs the end). Drift: motion frames available vs audio frames
arrived at the end. Each motion chunk is also made into the live socket's message (gesturelsm/webapp/live.py `payload`:
the page player's record); with --character PATH the same chunk is made a second time with the character section
(retargeted onto the character, gesturelsm/webapp/live_character.py), in the same run, so the two latencies (chunk
available + its message built) differ only by the character's cost. Every stream of a run (before and after; with
--grounding on off each grounded, feet on the ground causally: gesturelsm/grounding/causal.py, and not) is fed the same
chunks in one loop in an order that rotates chunk by chunk, each stream's latency leaving out the others' work in the
same step, so their latencies come from the same minutes of the same machine; the grounder's own time per motion chunk
is timed around it.

Feet (--feet): the two held-out audio-only takes streamed as fast as possible with grounding on and off (same seed),
measured as metrics/feet.py measures every method (foot skate, contact share, root drift and range, bob, floor
penetration, leg jerk) with the upper body's gesture space (raised share, p95 wrist height, wrist speed) beside.

Quality (as fast as possible, same seed): the held-out audio-only takes streamed with the live settings vs the
offline pipeline at the same steps: speech-response tests (metrics.speech_response), upper-body speed and jitter,
raised share and 95th-percentile wrist height (metrics.amplitude),
and upper-body jerk (|third difference| of joint positions) at chunk seams (the jerk values whose 4-frame stencil
spans a chunk start) over the jerk inside chunks; offline motion is scored at the same positions as a reference.

Pooled (--pooled N): the same two takes streamed with seeds 0 .. N-1 (what tests/live/test_stream.py asserts with
N = 6): loudness-following gain (mean, standard error, z, how many > 0), raised share and p95 wrist height averaged
over the streams. E.g. `--skip-paced --skip-quality --pooled 6 --cfg 2` for the numbers of another setting.
"""
from __future__ import annotations

from _harness import BEAT2, set_threads

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "benchmarks"))           # _live_sessions.py


def rss_mb() -> float:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2 ** 20


def messages(character: str | None, grounding: bool = True):
    """Functions chunk -> the socket's message bytes: the mannequin's record, and (with a character file) the record
    with the character section (its feet grounded on its own legs when `grounding`); each keeps its stream's state."""
    from dataclasses import replace

    from gesturelsm.body.model import resolve_body
    from gesturelsm.export.motion_codec import encode
    from gesturelsm.export.player_payload import motion_record

    body = resolve_body(None)
    out = {"mannequin": lambda mc: encode(motion_record(mc.motion, body, mc.start))}
    if character:
        from gesturelsm.retarget import load_character
        from gesturelsm.live.characters import CharacterStream

        stream = CharacterStream(load_character(character), body, grounding=grounding)

        def with_character(mc) -> bytes:
            q, r, w = stream.chunk(mc.motion)
            return encode(replace(motion_record(mc.motion, body, mc.start), bone_rotations=q, bone_root=r, morph=w))
        out[Path(character).name] = with_character
    return out


def live_stream(pipe, cfg, character: str | None) -> dict:
    """One paced stream's generator (its setting, grounded or not), its message builders and what it measured; the
    grounder's time per chunk is recorded around its `push`."""
    from gesturelsm.live import StreamingGenerator

    gen = StreamingGenerator(pipe, cfg)
    make = messages(character, cfg.grounding)
    st = {"gen": gen, "make": make, "lat": [], "ground_ms": [], "built": {k: [] for k in make}}
    if gen.grounder is not None:
        push = gen.grounder.push

        def timed(seq):
            t = time.perf_counter()
            out = push(seq)
            st["ground_ms"].append((time.perf_counter() - t) * 1000)
            return out
        gen.grounder.push = timed
    return st


def paced(pipe, audio: np.ndarray, cfgs: dict, chunk_ms: float, character: str | None = None) -> dict:
    """A paced run of one stream per named live setting of `cfgs` (a setting, grounded or not), fed the same chunks
    in one loop, the order of
    the streams rotating chunk by chunk; a stream's latencies leave out the time the other streams worked in the same
    step before it (as if it ran alone), while a step that overruns its chunk delays every stream's next one."""
    from gesturelsm.constants import SAMPLE_RATE

    n = int(round(chunk_ms * SAMPLE_RATE / 1000))
    modes = tuple(cfgs)
    streams = {m: live_stream(pipe, c, character) for m, c in cfgs.items()}
    mem = []
    c0, t0 = time.process_time(), time.perf_counter()
    for k, a in enumerate(range(0, len(audio), n)):
        chunk = audio[a:a + n]
        arrival = t0 + (a + len(chunk)) / SAMPLE_RATE
        time.sleep(max(0.0, arrival - time.perf_counter()))
        step0 = time.perf_counter()
        for m in modes[k % len(modes):] + modes[:k % len(modes)]:
            st = streams[m]
            waited = time.perf_counter() - step0           # the other streams' work this step: not this stream's
            for mc in st["gen"].feed(chunk, arrival):
                lat = [x - waited for x in mc.latencies]
                st["lat"] += lat
                for kind, f in st["make"].items():
                    t = time.perf_counter()
                    f(mc)
                    dt = time.perf_counter() - t
                    st["built"][kind].append((dt * 1000, [x + dt for x in lat]))
        mem.append((a / SAMPLE_RATE, rss_mb()))
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    m = np.array(mem)
    first = m[m[:, 0] <= 60, 1]
    out = {"cpu": cpu / wall, "cpu_per_audio_s": cpu / (len(audio) / SAMPLE_RATE),
           "mem_first_min": (first.min(), first.max()), "mem_end": m[-1, 1], "mem_max": m[:, 1].max(), "modes": {}}
    for mode, st in streams.items():
        gen = st["gen"]
        out["modes"][mode] = {"lat": np.array(st["lat"]), "rtf": len(audio) / SAMPLE_RATE / gen.compute_s,
                              "ground_ms": np.array(st["ground_ms"]), "built": st["built"], "frames": gen.emitted,
                              "compute_ms": 1000 * gen.compute_s / max(gen.window, 1),
                              "behind_frames": gen.n_in * 30 / SAMPLE_RATE - gen.emitted,   # audio without motion
                              "audio_frames": gen.n_in * 30 // SAMPLE_RATE}
    return out


def paced_tables(r: dict, seconds: float, take: str, chunk_ms: float) -> None:
    """Print the paced run: per stream (setting, grounded or not), side by side; then the run's CPU and memory (all
    streams)."""
    modes = list(r["modes"])
    cols = [r["modes"][m] for m in modes]
    print(f"| paced run ({seconds:.0f} s of {take}, {chunk_ms:.0f} ms chunks) | " + " | ".join(modes) + " |")
    print("|---|" + "---|" * len(modes))

    def row(name, f):
        print(f"| {name} | " + " | ".join(f(c) for c in cols) + " |")
    row("latency median / p90 / max (s)", lambda c: f"**{np.median(c['lat']):.3f}** / "
        f"**{np.percentile(c['lat'], 90):.3f}** / {c['lat'].max():.3f}")
    row("compute per window (ms, mean)", lambda c: f"{c['compute_ms']:.0f}")
    row("grounding per motion chunk median / p90 (ms)", lambda c: f"{np.median(c['ground_ms']):.1f} / "
        f"{np.percentile(c['ground_ms'], 90):.1f}" if len(c["ground_ms"]) else "-")
    row("real-time factor (audio s per compute s)", lambda c: f"{c['rtf']:.2f}")
    row("motion frames behind the audio at the end", lambda c: f"{c['behind_frames']:.0f} ({c['frames']} of "
        f"{c['audio_frames']})")
    if len(modes) == 2:
        a, b = (r["modes"][m]["lat"] for m in modes)
        print(f"| median latency {modes[0]} - {modes[1]} (ms) | {1000 * (np.median(a) - np.median(b)):+.1f} |  |")
    print()
    print(f"| the whole run ({len(modes)} stream{'s' if len(modes) > 1 else ''}) | value |")
    print("|---|---|")
    print(f"| CPU share (cores) / CPU seconds per audio second | {r['cpu']:.2f} / {r['cpu_per_audio_s']:.2f} |")
    print(f"| RSS first minute min-max / at end / max (MB) | {r['mem_first_min'][0]:.0f}-{r['mem_first_min'][1]:.0f}"
          f" / {r['mem_end']:.0f} / {r['mem_max']:.0f} |")
    print(f"| load average at the end (1 min) | {os.getloadavg()[0]:.1f} |\n")
    print("| stream | socket message | build per chunk median / p90 (ms) | latency incl. message median / p90 / "
          "max (s) |")
    print("|---|---|---|---|")
    for mode, c in zip(modes, cols):
        for k, rows in c["built"].items():
            ms = np.array([x for x, _ in rows])
            lat = np.concatenate([x for _, x in rows])
            print(f"| {mode} | {k} | {np.median(ms):.1f} / {np.percentile(ms, 90):.1f} | {np.median(lat):.3f} / "
                  f"{np.percentile(lat, 90):.3f} / {lat.max():.3f} |")
    print()


def quality(pipe, cfg, takes: list[str], offline_steps: int) -> list[tuple]:
    from gesturelsm.audio import load_audio
    from gesturelsm.body import load_body_model
    from gesturelsm.live.from_file import run_file
    from gesturelsm.metrics.amplitude import amplitude_stats
    from gesturelsm.metrics.beat import audio_beats, joint_speed
    from gesturelsm.metrics.speech_response import beat_timing, energy_following
    from gesturelsm.motion.regions import REGIONS

    body, upper = load_body_model(), list(REGIONS["upper"].joints)
    rows = []
    for name in takes:
        y = load_audio(BEAT2 / "wave16k" / f"{name}.wav")
        beats = audio_beats(y)
        live = run_file(pipe, y, cfg, 200.0)
        off = pipe.generate(y, 16000, steps=offline_steps, cfg=cfg.cfg, seed=cfg.seed, output="raw").motion
        seams = [c.start for c in live.chunks[1:]]
        for label, mot, borders in (("streamed", live.motion(), seams), ("offline", off, None)):
            j = body.joints(mot.poses, mot.trans)
            sp = joint_speed(j)[:, upper].mean()
            acc = (np.linalg.norm(j[2:] - 2 * j[1:-1] + j[:-2], axis=-1) * 900)[:, upper].mean()
            jerk = np.linalg.norm(np.diff(j[:, upper], n=3, axis=0), axis=-1).mean(1) * 27000   # (T-3,) m/s^3
            if borders is None:       # offline: the streamed run's seam positions, as a reference
                borders = seams
            at = np.zeros(len(jerk), bool)
            for b in borders:
                at[max(0, b - 3):b] = True
            rows.append((name, label, beat_timing(j, beats), energy_following(j, y), sp, acc,
                         jerk[at].mean() / jerk[~at].mean(), amplitude_stats(j)))
    return rows


def pooled(pipe, cfg, takes: list[str], seeds: int) -> str:
    from dataclasses import replace

    from gesturelsm.audio import load_audio
    from gesturelsm.body import load_body_model
    from gesturelsm.live.from_file import run_file
    from gesturelsm.metrics.amplitude import amplitude_stats
    from gesturelsm.metrics.speech_response import energy_following

    body, gains, amps = load_body_model(), [], []
    for name in takes:
        y = load_audio(BEAT2 / "wave16k" / f"{name}.wav")
        for seed in range(seeds):
            mot = run_file(pipe, y, replace(cfg, seed=seed), 200.0).motion()
            j = body.joints(mot.poses, mot.trans)
            gains.append(energy_following(j, y).gain)
            amps.append(amplitude_stats(j))
    g = np.array(gains)
    se = g.std(ddof=1) / np.sqrt(len(g))
    return (f"| {len(takes)} takes x seeds 0-{seeds - 1} | {g.mean():+.3f} | {se:.3f} | {g.mean() / se:.1f} | "
            f"{(g > 0).sum()} of {len(g)} | {100 * np.mean([a.raised_share for a in amps]):.1f} % | "
            f"{np.mean([a.height_p95 for a in amps]):.2f} |")


def feet_table(pipe, cfg, takes: list[str]) -> None:
    """Print the feet of streamed takes, grounded causally and not (module docstring)."""
    from dataclasses import replace

    from gesturelsm.audio import load_audio
    from gesturelsm.body import load_body_model
    from gesturelsm.live.from_file import run_file
    from gesturelsm.metrics.amplitude import amplitude_stats
    from gesturelsm.metrics.feet import feet_stats

    body = load_body_model()
    print("| take | grounding | foot skate (cm/s) | contact share | drift (m/min) | range (m) | bob (cm) | "
          "penetration p99 (cm) | leg jerk (m/s^3) | raised | p95 wrist height (m) | wrist speed (m/s) |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for name in takes:
        y = load_audio(BEAT2 / "wave16k" / f"{name}.wav")
        for on in (False, True):
            mot = run_file(pipe, y, replace(cfg, grounding=on), 200.0).motion()
            j = body.joints(mot.poses, mot.trans)
            f, a = feet_stats(j), amplitude_stats(j)
            print(f"| {name} | {'on' if on else 'off'} | {f.foot_skate:.1f} | {f.contact_share:.2f} | "
                  f"{f.drift_per_min:.2f} | {f.root_range:.2f} | {f.bob:.1f} | {f.penetration:.1f} | "
                  f"{f.leg_jerk:.0f} | {100 * a.raised_share:.1f} % | {a.height_p95:.3f} | {a.wrist_speed:.3f} |")


# The live setting main shipped before the half-second work (LiveConfig's values then): `--before main`
BEFORE = {"commit": 5, "lookahead": 1, "steps": 4, "cfg": 6.0, "decode_context": 16, "held": 0}


def settings(spec: str, base):
    """A LiveConfig from `base` with `key=value,...` applied (`main`: BEFORE)."""
    from dataclasses import fields, replace

    if spec == "main":
        return replace(base, **BEFORE)
    kinds = {f.name: type(getattr(base, f.name)) for f in fields(base)}
    over = {}
    for item in filter(None, spec.split(",")):
        k, _, v = item.partition("=")
        if k not in kinds:
            raise SystemExit(f"--before: no live setting {k!r} (one of {', '.join(kinds)})")
        over[k] = kinds[k](v) if kinds[k] is not bool else v.lower() in ("1", "true", "on")
    return replace(base, **over)


def quality_table(pipe, cfgs: dict) -> None:
    print("| setting | take | motion | beat timing gain (z) | loudness following gain (z) | upper speed (m/s) | "
          "jitter (m/s^2) | jerk at seams / inside | raised | p95 wrist height (m) |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for label_cfg, cfg in cfgs.items():
        for name, label, bt, ef, sp, acc, seam, amp in quality(pipe, cfg, TAKES, cfg.steps):
            print(f"| {label_cfg} | {name} | {label} | {bt.gain:+.3f} ({bt.z:.1f}) | {ef.gain:+.3f} ({ef.z:.1f}) | "
                  f"{sp:.3f} | {acc:.2f} | {seam:.2f} | {100 * amp.raised_share:.1f} % | {amp.height_p95:.2f} |")
    print()


TAKES = ["2_scott_0_2_2", "2_scott_0_3_3"]


def virtual_paced(pipe, cfg, audio: np.ndarray, block_ms: float):
    """Stream `audio` in `block_ms` blocks on a virtual clock of speech: block k arrives when its last sample would
    have been spoken, the generator works on it from max(its arrival, the end of the previous block's work) for as
    long as its `feed` really took on this machine (so a window that overruns pushes the next ones back, as in a
    paced run), without sleeping. The same again on a clock that advances by the CPU time the work took (this
    thread's, `time.thread_time`: what the work needs of a core of this machine when no other work shares it; on a
    loaded machine the wall clock adds the time other processes held the cores). Returns (delays of the blocks
    answered before the end of the speech, motion ready - block arrival, s: on the wall clock, on the CPU clock;
    every motion chunk incl. the end's; compute per window, ms of wall time)."""
    from collections import deque

    from gesturelsm.constants import SAMPLE_RATE
    from gesturelsm.live import StreamingGenerator

    gen = StreamingGenerator(pipe, cfg)
    n = max(1, int(round(block_ms * SAMPLE_RATE / 1000)))
    clock, cpu_clock, pending, delays, cpu_delays, chunks = 0.0, 0.0, deque(), [], [], []
    for a in range(0, len(audio), n):
        block = audio[a:a + n]
        arrival = (a + len(block)) / SAMPLE_RATE
        pending.append(arrival)
        v0, c0, r0, t0 = max(clock, arrival), max(cpu_clock, arrival), time.perf_counter(), time.thread_time()
        new = gen.feed(block)
        cpu_clock = c0 + time.thread_time() - t0          # a chunk is the last thing a feed makes: ready at its end
        for mc in new:
            for _ in mc.latencies:
                arrived = pending.popleft()
                delays.append(v0 + mc.produced - r0 - arrived)
                cpu_delays.append(cpu_clock - arrived)
            chunks.append(mc)
        clock = v0 + time.perf_counter() - r0
    chunks += gen.finish()
    return np.array(delays), np.array(cpu_delays), chunks, 1000 * gen.compute_s / max(gen.window, 1)


def sweep_stream(pipe, cfg, name: str, seconds: float, block_ms: float) -> dict:
    """One stream of the sweep: take `name` (its first `seconds`) with setting `cfg` on the virtual clock of speech
    (`virtual_paced`), and its motion's raised share, p95 wrist height, loudness following and jerk at seams over
    inside (as `quality`)."""
    from gesturelsm.audio import load_audio
    from gesturelsm.body import load_body_model
    from gesturelsm.metrics.amplitude import amplitude_stats
    from gesturelsm.metrics.speech_response import energy_following
    from gesturelsm.motion.regions import REGIONS
    from gesturelsm.motion.sequence import MotionSequence

    y = load_audio(BEAT2 / "wave16k" / f"{name}.wav")
    y = y[:int(seconds * 16000)] if seconds else y
    delays, cpu_delays, chunks, compute = virtual_paced(pipe, cfg, y, block_ms)
    mot = MotionSequence(np.concatenate([m.motion.poses for m in chunks]),
                         np.concatenate([m.motion.trans for m in chunks]),
                         np.concatenate([m.motion.expressions for m in chunks]))
    j = load_body_model().joints(mot.poses, mot.trans)
    amp = amplitude_stats(j)
    jerk = np.linalg.norm(np.diff(j[:, list(REGIONS["upper"].joints)], n=3, axis=0), axis=-1).mean(1)
    at = np.zeros(len(jerk), bool)
    for mc in chunks[1:]:
        at[max(0, mc.start - 3):mc.start] = True
    r = {"delay": delays, "cpu_delay": cpu_delays, "compute": compute, "raised": amp.raised_share,
         "height": amp.height_p95, "gain": energy_following(j, y).gain, "seam": jerk[at].mean() / jerk[~at].mean()}
    print(f"  {name} seed {cfg.seed} commit {cfg.commit} look-ahead {cfg.lookahead}: delay median "
          f"{np.median(cpu_delays):.3f} s (CPU clock; p90 {np.percentile(cpu_delays, 90):.3f}), "
          f"{np.median(delays):.3f} s (wall), raised {100 * r['raised']:.1f} %, p95 wrist height {r['height']:.3f}, "
          f"gain {r['gain']:+.3f}, seams {r['seam']:.2f}, load {os.getloadavg()[0]:.1f}", file=sys.stderr, flush=True)
    return r


_POOL_PIPE = None          # the pipeline the sweep's worker processes inherit (fork)


def _pool_stream(job):
    return job[0], job[1], sweep_stream(_POOL_PIPE, *job[2:])


def sweep(pipe, base, points: list[tuple[int, int]], takes: list[str], seeds: int, seconds: float,
          block_ms: float, jobs: int = 1, first_seed: int = 0) -> list[dict]:
    """Every (commit, look-ahead) of `points` (held, steps, CFG ... from `base`) on each held-out take (its first
    `seconds`) x seeds first_seed .. first_seed + seeds - 1, the settings interleaved stream by stream (so they
    share the same minutes of the machine; `jobs` > 1: that many streams at once, in forked processes):
    `sweep_stream` each."""
    from dataclasses import replace

    global _POOL_PIPE
    res = {p: {"delay": [], "cpu_delay": [], "compute": [], "raised": [], "height": [], "gain": [], "seam": []}
           for p in points}
    todo = [(c, la, replace(base, commit=c, lookahead=la, seed=seed), name, seconds, block_ms)
            for name in takes for seed in range(first_seed, first_seed + seeds) for c, la in points]
    if jobs > 1:
        import multiprocessing

        _POOL_PIPE = pipe
        with multiprocessing.get_context("fork").Pool(jobs) as pool:
            done = pool.map(_pool_stream, todo, chunksize=1)
    else:
        done = [(c, la, sweep_stream(pipe, *rest)) for c, la, *rest in todo]
    for c, la, r in done:
        for k, v in r.items():
            res[(c, la)][k].append(v)
    out = []
    for (c, la), r in res.items():
        d, dc, g = np.concatenate(r["delay"]), np.concatenate(r["cpu_delay"]), np.array(r["gain"])
        out.append({"commit": c, "lookahead": la, "wait_mean": (c / 2 + la) * 4 / 30, "wait_max": (c + la) * 4 / 30,
                    "median": float(np.median(dc)), "p90": float(np.percentile(dc, 90)),
                    "wall_median": float(np.median(d)), "wall_p90": float(np.percentile(d, 90)),
                    "compute": float(np.median(r["compute"])), "raised": float(np.mean(r["raised"])),
                    "height": float(np.mean(r["height"])), "gain": float(g.mean()),
                    "gain_se": float(g.std(ddof=1) / np.sqrt(len(g))) if len(g) > 1 else float("nan"),
                    "seam": float(np.mean(r["seam"]))})
    return out


QUALITY = ("raised", "height", "gain")     # within 10 % of the reference's (lower by at most 10 %); and seams smooth


def sweep_table(rows: list[dict], ref: tuple[int, int], streams: int) -> dict | None:
    """Print the sweep, every figure also in % of the reference setting's; returns the point with the lowest median
    delay whose raised share, p95 wrist height and loudness following are each at least 90 % of the reference's and
    whose jerk at seams is at most 1.1 x the reference's (or the inside's)."""
    base = next(r for r in rows if (r["commit"], r["lookahead"]) == ref)

    def rel(r, k):
        return f"{100 * (r[k] / base[k] - 1):+.0f} %" if base[k] else "-"
    print("| commit / look-ahead (latents) | wait for speech mean / worst (s) | delay median (s) | vs ref | "
          "delay p90 (s) | vs ref | wall clock: delay median / p90 (s), compute per window (ms) | raised | vs ref | "
          "p95 wrist height (m) | vs ref | loudness following (SE) | vs ref | jerk at seams / inside | vs ref |")
    print("|---|" + "---|" * 15)
    ok = [r for r in rows if all(r[k] >= 0.9 * base[k] for k in QUALITY) and r["seam"] <= max(1.1 * base["seam"], 1)]
    best = min(ok, key=lambda r: r["median"]) if ok else None
    for r in rows:
        tag = " (reference)" if r is base else ""
        tag += " **best within 10 %**" if r is best else ""
        print(f"| {r['commit']} / {r['lookahead']}{tag} | {r['wait_mean']:.2f} / {r['wait_max']:.2f} | "
              f"{r['median']:.3f} | {rel(r, 'median')} | {r['p90']:.3f} | {rel(r, 'p90')} | {r['wall_median']:.3f} / "
              f"{r['wall_p90']:.3f}, {r['compute']:.0f} | "
              f"{100 * r['raised']:.1f} % | {rel(r, 'raised')} | {r['height']:.3f} | {rel(r, 'height')} | "
              f"{r['gain']:+.3f} ({r['gain_se']:.3f}) | {rel(r, 'gain')} | {r['seam']:.2f} | {rel(r, 'seam')} |")
    print(f"\n({streams} streams per setting; quality: means over them; delay: median / p90 over all their blocks, "
          f"on the clock of the CPU time the work took, and on the wall clock of this machine beside)\n")
    return best


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seconds", type=float, default=60.0, help="paced run length (the take is looped)")
    ap.add_argument("--chunk-ms", type=float, default=200.0)
    ap.add_argument("--threads", type=int, default=1, help="torch threads (2 oversubscribes a shared 2-core machine)")
    ap.add_argument("--steps", type=int, default=None, help="sampler steps (default: LiveConfig's)")
    ap.add_argument("--commit", type=int, default=None)
    ap.add_argument("--cfg", type=float, default=None, help="guidance scale (default: LiveConfig's)")
    ap.add_argument("--lookahead", type=int, default=None)
    ap.add_argument("--before", default="main", metavar="SPEC", help="also stream this setting beside the one "
                    "measured, in the same runs: `main` (the setting main shipped before, BEFORE), `key=value,...` "
                    "over LiveConfig's defaults, or `none`")
    ap.add_argument("--streams", type=int, default=0, metavar="N", help="also run N live sessions at once (the "
                    "server's worker threads), paced, with the setting measured")
    ap.add_argument("--take", default="2_scott_0_2_2")
    ap.add_argument("--skip-quality", action="store_true")
    ap.add_argument("--skip-paced", action="store_true")
    ap.add_argument("--pooled", type=int, default=0, metavar="N", help="also stream both takes with seeds 0..N-1")
    ap.add_argument("--grounding", nargs="+", choices=("on", "off"), default=["on"],
                    help="feet on the ground in the paced run: on, off, or `on off` for both streams in one run, "
                    "interleaved (the latency before and after grounding)")
    ap.add_argument("--feet", action="store_true", help="also the feet of the two held-out takes, streamed grounded "
                    "and not")
    ap.add_argument("--character", metavar="PATH", help="also build each chunk's message on this character (.vrm, "
                    ".glb, .gltf, .bvh): the latency with and without it")
    ap.add_argument("--sweep", nargs="+", default=None, metavar="C/L", help="the curve of delay against quality: "
                    "these commit/look-ahead points (e.g. 3/1 1/1 2/0; held, steps, CFG as measured), each streamed on "
                    "the held-out takes on a virtual clock of speech (table: each figure vs the first point's)")
    ap.add_argument("--sweep-seeds", type=int, default=2, help="seeds per take in the sweep")
    ap.add_argument("--sweep-first-seed", type=int, default=0, help="the sweep's seeds start here")
    ap.add_argument("--sweep-seconds", type=float, default=0, help="the first S seconds of each take (0: all)")
    ap.add_argument("--sweep-jobs", type=int, default=1, help="streams of the sweep at once (processes; each "
                    "stream's delay counts its own CPU time)")
    ap.add_argument("--block-ms", type=float, default=50.0, help="the sweep's audio blocks (the page sends 50 ms)")
    args = ap.parse_args()
    set_threads(args.threads)
    from dataclasses import replace

    from gesturelsm.audio import load_audio
    from gesturelsm.live import LiveConfig
    from gesturelsm.pipeline import GesturePipeline

    if not BEAT2.exists():
        raise SystemExit(f"needs the real speech takes at {BEAT2}")
    given = (("steps", args.steps), ("commit", args.commit), ("lookahead", args.lookahead), ("cfg", args.cfg))
    cfg = replace(LiveConfig(), **{k: v for k, v in given if v is not None})
    cfgs = {"measured": cfg} if args.before == "none" else {"before": settings(args.before, LiveConfig()),
                                                             "after": cfg}
    pipe = GesturePipeline.from_pretrained(methods=[cfg.method])
    for name, c in cfgs.items():
        print(f"{name}: {c}; audio look-ahead <= {(c.commit + c.lookahead) * 4 / 30:.2f} s")
    print(f"torch threads {args.threads}; load average at start {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores\n")
    take = load_audio(BEAT2 / "wave16k" / f"{args.take}.wav")
    y = np.tile(take, int(np.ceil(args.seconds * 16000 / len(take))))[:int(args.seconds * 16000)]
    if args.sweep:
        points = [tuple(int(v) for v in p.split("/")) for p in args.sweep]
        virtual_paced(pipe, cfg, y[:3 * 16000], args.block_ms)         # JIT and caches outside the measurement
        rows = sweep(pipe, cfg, points, TAKES, args.sweep_seeds, args.sweep_seconds, args.block_ms, args.sweep_jobs,
                     args.sweep_first_seed)
        sweep_table(rows, points[0], len(TAKES) * args.sweep_seeds)
        print(f"load average at the end (1 min) {os.getloadavg()[0]:.1f}\n")
    if not args.skip_paced:
        modes = tuple(dict.fromkeys(args.grounding))
        streams = {(k if len(modes) == 1 else f"{k}, grounding {m}"): replace(c, grounding=m == "on")
                   for k, c in cfgs.items() for m in modes}
        paced_tables(paced(pipe, y, streams, args.chunk_ms, args.character), args.seconds, args.take, args.chunk_ms)
    if args.streams:
        from _live_sessions import simultaneous, simultaneous_table

        simultaneous_table(simultaneous(pipe, y, cfg, args.streams, args.chunk_ms), args.seconds, args.chunk_ms)
    if not args.skip_quality:
        quality_table(pipe, cfgs)
    if args.feet:
        feet_table(pipe, cfg, TAKES)
    if args.pooled:
        print("| setting | streamed (pooled) | loudness gain, mean | standard error | z | gains > 0 | raised | "
              "p95 wrist height (m) |")
        print("|---|---|---|---|---|---|---|---|")
        for name, c in cfgs.items():
            print(f"| {name} " + pooled(pipe, c, TAKES, args.pooled), flush=True)


if __name__ == "__main__":
    main()
