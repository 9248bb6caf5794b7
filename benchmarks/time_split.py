"""Where the time of the page's two paths goes, stage by stage, on this machine (the profile behind the latency work).

    .venv/bin/python benchmarks/time_split.py                                   # both tables
    .venv/bin/python benchmarks/time_split.py --seconds 10 60 --repeat 3 --skip-live
    .venv/bin/python benchmarks/time_split.py --fresh-kernels --warmup 1        # the first visitor after a 1 s warm-up
    .venv/bin/python benchmarks/time_split.py --skip-request --skip-live --schedules   # sequential vs parallel methods

Generate (server side, in this process; the browser's part is benchmarks/player_latency.py): a GestureService over the
shipped checkpoints, warmed up (`--warmup` lengths, default the service's), eSpeak NG speech (as app/measure.py) of each
--seconds, the default three methods. Each repeat uploads speech of its own content (transcribed afresh), prepares it
as the page does at the upload (`GestureService.prefetch`), then clicks: `GestureService.stream` with the page's
settings, each method's result timed as it arrives, then the player's files. Stages are timed around the functions
that do them (decoding, audio features, transcription, word features, post-processing with grounding, player files);
sampling and decoding are the methods' own timings. Medians over --repeat; the first repeat of a process is printed
apart (what lazy first-call costs are left after the warm-up; --fresh-kernels keeps the kernels' choices in memory
only, as on a machine that has measured none).

Live (one stream, as fast as possible, torch 1 thread): --live-seconds of the held-out take fed in 50 ms blocks, per
window: audio features, speech encoder, sampling (all steps), decoding, grounding, the socket message; for each
`--live` setting (key=value,...; default: the setting main shipped before and this checkout's LiveConfig).
"""
from __future__ import annotations

from _harness import set_threads

import argparse
import functools
import os
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path
from statistics import median

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "benchmarks"))
METHODS = ("gesturelsm", "rectified_flow", "ddim")


def timer(store: dict, obj, name: str, key: str) -> None:
    """Time every call of obj.name into store[key] (seconds, appended)."""
    f = getattr(obj, name)

    @functools.wraps(f)
    def g(*a, **k):
        t = time.perf_counter()
        try:
            return f(*a, **k)
        finally:
            store[key].append(time.perf_counter() - t)
    setattr(obj, name, g)


def one_request(service, wav: Path, T: dict) -> dict:
    """Upload-time preparation, then the click; seconds per stage and per method's arrival."""
    from gesturelsm.serve.request import Request
    from gesturelsm.webapp.player import component

    T.clear()
    t0 = time.perf_counter()
    service.prefetch(str(wav))
    out = {"upload: prepared in all": time.perf_counter() - t0}
    for k in ("decode", "audio features", "transcription", "word features"):
        out[f"upload: {k}"] = sum(T.pop(k, []))
    req = Request(str(wav), methods=list(METHODS), exports=False, render=False)
    t0 = time.perf_counter()
    last = None
    for res in service.stream(req):
        now = time.perf_counter() - t0
        new = [m for m in res.motions if last is None or m not in last.motions]
        for m in new:
            out[f"click: {m} ready"] = now
            for k, v in res.timings[m].items():
                if k in ("sampling", "decoding"):
                    out[f"click: {m} {k}"] = v
        if last is None:
            out["click: speech ready (first result)"] = now
        t1 = time.perf_counter()
        component.payload(service, res)
        out.setdefault("click: player files (all results)", 0.0)
        out["click: player files (all results)"] += time.perf_counter() - t1
        last = res
    for k in ("decode", "transcription", "audio features", "word features", "post-processing"):
        out[f"click: {k}"] = sum(T.pop(k, []))
    out["click: all made"] = time.perf_counter() - t0
    return out


def request_table(args) -> None:
    from app.measure import speech
    from gesturelsm.serve.config import ServiceSettings
    from gesturelsm.serve.service import WARMUP_SECONDS, GestureService
    import gesturelsm.pipeline as P
    import gesturelsm.serve.service as S

    service = GestureService.from_settings(ServiceSettings(max_seconds=600))
    warm = tuple(args.warmup) if args.warmup else WARMUP_SECONDS
    w = service.warmup(seconds=warm)
    T: dict = defaultdict(list)
    timer(T, S, "load_audio", "decode")
    timer(T, P, "audio_channels", "audio features")
    timer(T, P, "automatic_words", "transcription")
    timer(T, P.TextEmbedder, "frame_features", "word features")
    timer(T, P, "finish", "post-processing")
    print(f"warm-up on {', '.join(f'{s:g}' for s in warm)} s of speech: {w:.1f} s; load average "
          f"{os.getloadavg()[0]:.1f} on {os.cpu_count()} cores\n")
    cols, runs = [], {}
    with tempfile.TemporaryDirectory() as tmp:
        for sec in args.seconds:
            wav0, _, dur = speech(sec, Path(tmp) / f"s{sec:g}.wav")
            import soundfile as sf
            y, sr = sf.read(wav0, dtype="float32")
            for r in range(args.repeat):
                wav = Path(tmp) / f"s{sec:g}-{r}.wav"
                sf.write(wav, y * (1 - 1e-3 * r), sr)           # other content: transcribed afresh
                runs.setdefault(dur, []).append(one_request(service, wav, T))
    for dur, rs in runs.items():
        cols.append((f"{dur:.0f} s, first", rs[0]))
        if len(rs) > 1:
            cols.append((f"{dur:.0f} s, median of {len(rs) - 1} after",
                         {k: median(x[k] for x in rs[1:]) for k in rs[1]}))
    keys = list(dict.fromkeys(k for _, c in cols for k in c))
    print("| stage (s) | " + " | ".join(n for n, _ in cols) + " |\n|---|" + "---|" * len(cols))
    for k in keys:
        print(f"| {k} | " + " | ".join(f"{c[k]:.3f}" if k in c else "" for _, c in cols) + " |")
    print()


def live_table(args) -> None:

    from live_latency import BEAT2, settings
    from gesturelsm.audio import load_audio
    from gesturelsm.body.model import resolve_body
    from gesturelsm.export.motion_codec import encode
    from gesturelsm.export.player_payload import motion_record
    from gesturelsm.live import LiveConfig, StreamingGenerator
    from gesturelsm.live import stream as S
    from gesturelsm.pipeline import GesturePipeline

    set_threads(1)
    pipe = GesturePipeline.from_pretrained(methods=["gesturelsm"])
    body = resolve_body(None)
    y = load_audio(BEAT2 / "wave16k" / "2_scott_0_2_2.wav")[:int(args.live_seconds * 16000)]
    specs = args.live or ["main", ""]
    cols = []
    for spec in specs:
        cfg = settings(spec, LiveConfig())
        list(StreamingGenerator(pipe, cfg).stream([y[:16000 * 6]]))          # first calls of every shape
        T: dict = defaultdict(list)
        gen = StreamingGenerator(pipe, cfg)
        saved = {k: getattr(S, k) for k in ("audio_channels", "decode_latents")}
        timer(T, S, "audio_channels", "audio features")
        timer(T, S, "decode_latents", "decoding (RVQ-VAE)")
        pre = gen.model.speech.register_forward_pre_hook(lambda *a: T["_s"].append(time.perf_counter()))
        post = gen.model.speech.register_forward_hook(
            lambda *a: T["speech encoder"].append(time.perf_counter() - T["_s"].pop()))
        timer(T, gen.method, "sample", f"sampling ({cfg.steps} steps, CFG {cfg.cfg:g})")
        if gen.grounder is not None:
            timer(T, gen.grounder, "push", "grounding")
        timer(T, gen, "_run_window", "window in all")
        for a in range(0, len(y), 800):
            for mc in gen.feed(y[a:a + 800]):
                t = time.perf_counter()
                encode(motion_record(mc.motion, body, mc.start))
                T["socket message"].append(time.perf_counter() - t)
        pre.remove(), post.remove()
        for k, v in saved.items():
            setattr(S, k, v)
        n = max(1, len(T["window in all"]))
        col = {k: 1000 * sum(v) / n for k, v in T.items() if not k.startswith("_")}
        col["windows per audio second"] = n / (len(y) / 16000)
        col["wait for speech, mean (ms)"] = 1000 * (cfg.lookahead + cfg.commit / 2) * 4 / 30
        cols.append((f"{spec or 'this checkout'}: commit {cfg.commit} / look-ahead {cfg.lookahead}"
                     f"{f' / held {cfg.held}' if cfg.held else ''}", col))
    keys = list(dict.fromkeys(k for _, c in cols for k in c))
    print(f"live, ms per window (mean), {args.live_seconds:g} s of speech, 50 ms blocks, torch 1 thread; load average "
          f"{os.getloadavg()[0]:.1f}\n")
    print("| stage | " + " | ".join(n for n, _ in cols) + " |\n|---|" + "---|" * len(cols))
    for k in keys:
        print(f"| {k} | " + " | ".join(f"{c[k]:.1f}" if k in c else "" for _, c in cols) + " |")
    print(f"\n(rows are means per window; the load average at the end was {os.getloadavg()[0]:.1f})")


def schedule_table(args) -> None:
    """The three methods on 10 s of held-out speech (audio only), one after another at 1 and 2 math threads, and
    all three at once in threads of one math thread each: when the first is ready and when all are."""
    from concurrent.futures import ThreadPoolExecutor


    from live_latency import BEAT2
    from gesturelsm.audio import load_audio
    from gesturelsm.pipeline import GesturePipeline

    pipe = GesturePipeline.from_pretrained()
    y = load_audio(BEAT2 / "wave16k" / "2_scott_0_2_2.wav")[:160000]
    sp = pipe.prepare_speech(y, transcribe=False)
    steps = {"gesturelsm": 8, "rectified_flow": 8, "ddim": 20}

    def one(m: str, threads: int, t0: float) -> float:
        set_threads(threads)
        pipe.generate(sp, steps=steps[m], method=m, output="raw")
        return time.perf_counter() - t0

    def sequential(threads: int) -> list[float]:
        t0 = time.perf_counter()
        return [one(m, threads, t0) for m in steps]

    def parallel() -> list[float]:
        t0 = time.perf_counter()
        with ThreadPoolExecutor(len(steps)) as ex:
            return list(ex.map(lambda m: one(m, 1, t0), steps))
    runs = {"one after another, 1 math thread": lambda: sequential(1),
            "one after another, 2 math threads": lambda: sequential(2),
            "all three at once, 1 math thread each": parallel}
    for f in runs.values():
        f()                                                  # first calls of every shape at both thread counts
    got: dict = {k: [] for k in runs}
    for _ in range(args.repeat):
        for k, f in runs.items():                            # interleaved
            got[k].append(f())
    print(f"scheduling the three methods (10 s of speech; medians of {args.repeat}, interleaved; load average "
          f"{os.getloadavg()[0]:.1f})\n\n| schedule | first ready (s) | all ready (s) |\n|---|---|---|")
    for k, rs in got.items():
        print(f"| {k} | {median(min(r) for r in rs):.2f} | {median(max(r) for r in rs):.2f} |")
    print()


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--seconds", type=float, nargs="+", default=[10, 60])
    p.add_argument("--repeat", type=int, default=4, help="requests per length (the first is printed apart)")
    p.add_argument("--warmup", type=float, nargs="+", help="warm-up speech lengths (default: the service's)")
    p.add_argument("--fresh-kernels", action="store_true", help="the kernels' choices in memory only (a new machine)")
    p.add_argument("--skip-request", action="store_true")
    p.add_argument("--skip-live", action="store_true")
    p.add_argument("--schedules", action="store_true", help="also: the methods one after another at 1 and 2 math "
                   "threads against all at once")
    p.add_argument("--live-seconds", type=float, default=40.0)
    p.add_argument("--live", nargs="+", metavar="SPEC", help="live settings (key=value,...; `main`; '' = defaults)")
    args = p.parse_args()
    os.environ.setdefault("GRADIO_ANALYTICS_ENABLED", "False")
    os.environ.setdefault("HF_HUB_DISABLE_TELEMETRY", "1")
    if args.fresh_kernels:
        os.environ["GESTURELSM_KERNELS_CACHE"] = ""
    if not args.skip_request:
        request_table(args)                  # math threads as the app has them (torch's default)
    if args.schedules:
        schedule_table(args)
    if not args.skip_live:
        live_table(args)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
