"""Upload-to-video time of the served app as a visitor sees it: gradio_client uploads the speech and calls
`/generate` (the video and the downloads in one call), for eSpeak NG
speech of the given lengths, one method and three side by side, without and with a transcript.
Prints a markdown table.

    .venv/bin/python -m app.measure --seconds 10 60 [--checkpoints DIR] [--size 384]
"""
from __future__ import annotations

import os

os.environ["GRADIO_ANALYTICS_ENABLED"] = "False"
os.environ["HF_HUB_DISABLE_TELEMETRY"] = "1"

import argparse
import subprocess
import tempfile
import time
from pathlib import Path

from gesturelsm.audio import load_audio

# Varied sentences, none repeated within 30 s: Whisper re-decodes a 30 s window whose text compresses too well
# (a repeated sentence) at five more temperatures, so 60 s of one repeated sentence takes ~21 s to
# transcribe instead of ~3.5 s per minute of real speech (benchmarks/transcribe_accuracy.py).
SENTENCES = (
    "When we talk about the weather, we often move our hands to show the clouds, the wind and the sun.",
    "Then we point at the sky and explain why tomorrow will be better than today.",
    "My grandmother kept a small garden behind the house, full of tomatoes, beans and bright yellow flowers.",
    "Every summer we picked the fruit together and carried heavy baskets into the kitchen.",
    "Learning to cook took me years, and I still burn the rice when I am not paying attention.",
    "The train to the city leaves at seven, so most mornings I run down the hill with my coffee.",
    "Honestly, the best part of travelling is getting lost in a market where nobody speaks your language.",
    "You point, you smile, you count on your fingers, and somehow everyone understands each other.",
    "Last winter the lake froze so thick that whole families walked across it to the island.",
    "Our teacher used to say that a good question is worth more than a quick answer.",
    "If you want to build a boat, start with a drawing, then a model, and only then the real wood.",
    "Music was always loud in our house, and my brother practised the drums right above my bedroom.",
    "Nobody expected the small bakery on the corner to become famous for its enormous cinnamon rolls.",
    "We argued for hours about the ending of that film, and we still do not agree.",
    "The mountains look close from the window, but the road takes almost three hours.",
    "At the end of the day, what people remember is how you made them feel.",
)


def speech(seconds: float, out: Path) -> tuple[Path, str, float]:
    """eSpeak NG speech of about `seconds` (whole words), its text and its duration."""
    import soundfile as sf

    words = (" ".join(SENTENCES).split() * (int(seconds // 60) + 1))[: max(3, int(seconds * 2.9))]
    text = " ".join(words)
    raw = out.with_suffix(".raw.wav")
    subprocess.run(["espeak-ng", "-s", "150", "-w", str(raw), text], check=True)
    y = load_audio(raw)
    sf.write(out, y, 16000)
    return out, text, len(y) / 16000


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--seconds", type=float, nargs="+", default=[10, 60])
    p.add_argument("--checkpoints")
    p.add_argument("--size", type=int, default=384)
    p.add_argument("--steps", type=int, default=8)
    args = p.parse_args(argv)
    from gradio_client import Client, handle_file

    # lazy: the service loads torch and the checkpoints, .ui imports gradio; only once the arguments are read
    from gesturelsm.serve.config import ServiceSettings
    from gesturelsm.serve.service import GestureService

    from gesturelsm.webapp.ui import serve_locally

    service = GestureService.from_settings(ServiceSettings(checkpoints=args.checkpoints, max_seconds=600))
    service.warmup()
    demo, url = serve_locally(service)
    client = Client(url, verbose=False)
    sets = [["gesturelsm"], ["gesturelsm", "rectified_flow", "ddim"]]
    print(f"steps {args.steps} (DDIM 20), CFG 2, tiles {args.size} x {args.size}; times from the upload call")
    print("| speech | methods | text | upload to video (s) | rendering (s) | generation per method (s) |")
    print("|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for sec in args.seconds:
            wav, words, dur = speech(sec, Path(tmp) / f"speech_{int(sec)}.wav")
            for methods in sets:
                for text in ("", words):
                    t0 = time.perf_counter()
                    video, table, *_ = client.predict(handle_file(str(wav)), text, None, methods, args.steps, 2.0, 0,
                                                      20, False, "off", args.size, api_name="/generate")
                    dt = time.perf_counter() - t0
                    rows = table["data"]
                    gens = ", ".join(f"{r[0]} {r[6]:.2f}" for r in rows[:-1])
                    print(f"| {dur:.1f} s | {' + '.join(methods)} | {'transcript' if text else 'audio only'} | "
                          f"{dt:.1f} | {rows[-1][5]:.1f} | {gens} |", flush=True)
    demo.close()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
