"""Live mode on this machine: latency, CPU share, memory, drift, and streamed vs offline quality.

    .venv/bin/python benchmarks/live_latency.py                       # 60 s paced run + quality on two takes
    .venv/bin/python benchmarks/live_latency.py --seconds 600         # 10 minutes (the real take looped)
    .venv/bin/python benchmarks/live_latency.py --skip-quality --threads 2
    .venv/bin/python benchmarks/live_latency.py --skip-quality --character avatar.vrm   # also on a character

Paced run: a real take (../shared) looped to --seconds, fed in --chunk-ms chunks at the pace of speech (chunk k
arrives when its last sample would have been spoken). Latency of a chunk = when the motion of all its frames is
available - its arrival. CPU share = process CPU time / wall time (1.0 = one core busy). Memory: resident set size
sampled each chunk (first minute vs the end). Drift: motion frames available vs audio frames arrived at the end.
Each motion chunk is also made into the live socket's message (gesturelsm/webapp/live.py `payload`: the page
player's record); with --character PATH the same chunk is made a second time with the character section (retargeted
onto the character, gesturelsm/webapp/live_character.py), in the same run, so the two latencies (chunk available +
its message built) differ only by the character's cost.

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

import argparse
import os
import time
from pathlib import Path

import numpy as np
import torch

REPO = Path(__file__).resolve().parents[1]
BEAT2 = Path(os.environ.get("GESTURELSM_SHARED", REPO.parent / "shared")) / "data" / "beat2"


def rss_mb() -> float:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2 ** 20


def messages(character: str | None):
    """Functions chunk -> the socket's message bytes: the mannequin's record, and (with a character file) the record
    with the character section; each keeps its stream's state."""
    from dataclasses import replace

    from gesturelsm.body.model import resolve_body
    from gesturelsm.export.motion_codec import encode
    from gesturelsm.export.player_payload import motion_record

    body = resolve_body(None)
    out = {"mannequin": lambda mc: encode(motion_record(mc.motion, body, mc.start))}
    if character:
        from gesturelsm.retarget import load_character
        from gesturelsm.webapp.live_character import CharacterStream

        stream = CharacterStream(load_character(character), body)

        def with_character(mc) -> bytes:
            q, r, w = stream.chunk(mc.motion)
            return encode(replace(motion_record(mc.motion, body, mc.start), bone_rotations=q, bone_root=r, morph=w))
        out[Path(character).name] = with_character
    return out


def paced(pipe, audio: np.ndarray, cfg, chunk_ms: float, character: str | None = None) -> dict:
    from gesturelsm.live import StreamingGenerator
    from gesturelsm.constants import SAMPLE_RATE

    n = int(round(chunk_ms * SAMPLE_RATE / 1000))
    gen = StreamingGenerator(pipe, cfg)
    make = messages(character)
    lat, mem, built = [], [], {k: [] for k in make}          # built: per message kind, (ms to build, latencies)
    c0, t0 = time.process_time(), time.perf_counter()
    for a in range(0, len(audio), n):
        chunk = audio[a:a + n]
        arrival = t0 + (a + len(chunk)) / SAMPLE_RATE
        time.sleep(max(0.0, arrival - time.perf_counter()))
        for mc in gen.feed(chunk, arrival):
            lat += mc.latencies
            for k, f in make.items():
                t = time.perf_counter()
                f(mc)
                dt = time.perf_counter() - t
                built[k].append((dt * 1000, [x + dt for x in mc.latencies]))
        mem.append((a / SAMPLE_RATE, rss_mb()))
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    behind = gen.n_in * 30 / SAMPLE_RATE - gen.emitted                            # frames of audio without motion yet
    m = np.array(mem)
    first = m[m[:, 0] <= 60, 1]
    return {"lat": np.array(lat), "cpu": cpu / wall, "cpu_per_audio_s": cpu / (len(audio) / SAMPLE_RATE), "rtf": len(audio) / SAMPLE_RATE / gen.compute_s,
            "mem_first_min": (first.min(), first.max()), "mem_end": m[-1, 1], "mem_max": m[:, 1].max(),
            "behind_frames": behind, "frames": gen.emitted, "audio_frames": gen.n_in * 30 // SAMPLE_RATE,
            "built": built}


def quality(pipe, cfg, takes: list[str], offline_steps: int) -> list[tuple]:
    from gesturelsm.audio import load_audio
    from gesturelsm.body import load_body_model
    from gesturelsm.live.cli import run_file
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
        off = pipe.generate(y, 16000, steps=offline_steps, cfg=cfg.cfg, seed=cfg.seed).motion
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
    from gesturelsm.live.cli import run_file
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


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seconds", type=float, default=60.0, help="paced run length (the take is looped)")
    ap.add_argument("--chunk-ms", type=float, default=200.0)
    ap.add_argument("--threads", type=int, default=1, help="torch threads (2 oversubscribes a shared 2-core machine)")
    ap.add_argument("--steps", type=int, default=None, help="sampler steps (default: LiveConfig's)")
    ap.add_argument("--commit", type=int, default=None)
    ap.add_argument("--cfg", type=float, default=None, help="guidance scale (default: LiveConfig's)")
    ap.add_argument("--lookahead", type=int, default=None)
    ap.add_argument("--take", default="2_scott_0_2_2")
    ap.add_argument("--skip-quality", action="store_true")
    ap.add_argument("--skip-paced", action="store_true")
    ap.add_argument("--pooled", type=int, default=0, metavar="N", help="also stream both takes with seeds 0..N-1")
    ap.add_argument("--character", metavar="PATH", help="also build each chunk's message on this character (.vrm, "
                    ".glb, .gltf, .bvh): the latency with and without it")
    args = ap.parse_args()
    torch.set_num_threads(args.threads)
    from dataclasses import replace

    from gesturelsm.audio import load_audio
    from gesturelsm.live import LiveConfig
    from gesturelsm.pipeline import GesturePipeline

    if not BEAT2.exists():
        raise SystemExit(f"needs the real speech takes at {BEAT2}")
    given = (("steps", args.steps), ("commit", args.commit), ("lookahead", args.lookahead), ("cfg", args.cfg))
    cfg = replace(LiveConfig(), **{k: v for k, v in given if v is not None})
    pipe = GesturePipeline.from_pretrained(methods=[cfg.method])
    look = (cfg.commit + cfg.lookahead) * 4 / 30
    print(f"settings: {cfg}; audio look-ahead <= {look:.2f} s; torch threads {args.threads}; "
          f"load average at start {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores\n")
    if not args.skip_paced:
        take = load_audio(BEAT2 / "wave16k" / f"{args.take}.wav")
        y = np.tile(take, int(np.ceil(args.seconds * 16000 / len(take))))[:int(args.seconds * 16000)]
        r = paced(pipe, y, cfg, args.chunk_ms, args.character)
        print(f"| paced run ({args.seconds:.0f} s of {args.take}, {args.chunk_ms:.0f} ms chunks) | value |")
        print("|---|---|")
        print(f"| latency median / p90 / max (s) | {np.median(r['lat']):.2f} / {np.percentile(r['lat'], 90):.2f} / "
              f"{r['lat'].max():.2f} |")
        print(f"| real-time factor (audio s per compute s) | {r['rtf']:.2f} |")
        print(f"| CPU share (cores) / CPU seconds per audio second | {r['cpu']:.2f} / {r['cpu_per_audio_s']:.2f} |")
        print(f"| RSS first minute min-max / at end / max (MB) | {r['mem_first_min'][0]:.0f}-{r['mem_first_min'][1]:.0f}"
              f" / {r['mem_end']:.0f} / {r['mem_max']:.0f} |")
        print(f"| motion frames behind the audio at the end | {r['behind_frames']:.0f} "
              f"({r['frames']} of {r['audio_frames']}) |")
        print(f"| load average at the end (1 min) | {os.getloadavg()[0]:.1f} |\n")
        print("| socket message | build per chunk median / p90 (ms) | latency incl. message median / p90 / max (s) |")
        print("|---|---|---|")
        for k, rows in r["built"].items():
            ms = np.array([m for m, _ in rows])
            lat = np.concatenate([x for _, x in rows])
            print(f"| {k} | {np.median(ms):.1f} / {np.percentile(ms, 90):.1f} | {np.median(lat):.3f} / "
                  f"{np.percentile(lat, 90):.3f} / {lat.max():.3f} |")
        print()
    if not args.skip_quality:
        rows = quality(pipe, cfg, ["2_scott_0_2_2", "2_scott_0_3_3"], cfg.steps)
        print("| take | motion | beat timing gain (z) | loudness following gain (z) | upper speed (m/s) | "
              "jitter (m/s^2) | jerk at seams / inside | raised | p95 wrist height (m) |")
        print("|---|---|---|---|---|---|---|---|---|")
        for name, label, bt, ef, sp, acc, seam, amp in rows:
            print(f"| {name} | {label} | {bt.gain:+.3f} ({bt.z:.1f}) | {ef.gain:+.3f} ({ef.z:.1f}) | {sp:.3f} | "
                  f"{acc:.2f} | {seam:.2f} | {100 * amp.raised_share:.1f} % | {amp.height_p95:.2f} |")
    if args.pooled:
        print("\n| streamed (pooled) | loudness gain, mean | standard error | z | gains > 0 | raised | "
              "p95 wrist height (m) |")
        print("|---|---|---|---|---|---|---|")
        print(pooled(pipe, cfg, ["2_scott_0_2_2", "2_scott_0_3_3"], args.pooled))


if __name__ == "__main__":
    main()
