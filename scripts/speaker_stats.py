"""Compute the shipped speaker's reference row for the page and `gesturelsm sweep` (assets/speaker_stats.json).

    .venv/bin/python scripts/speaker_stats.py [--data ../shared/data/beat2] [--out assets/speaker_stats.json]

The row is gesturelsm.evaluation.motion_stats' statistics of every motion take of the BEAT2-layout folder (the
speaker the shipped generators were trained on), each against its own speech, on the shipped mannequin; with
several takes, each statistic is the mean over takes weighted by their length and BC's per-joint mean speeds are
pooled over all frames. The result is committed so that the page needs no dataset.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from gesturelsm.data.beat2 import Beat2Dataset  # noqa: E402
from gesturelsm.evaluation.motion_stats import (SPEAKER_FILE, SpeakerReference, save_speaker_reference,  # noqa: E402
                                                speaker_statistics)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default=str(ROOT.parent / "shared" / "data" / "beat2"))
    ap.add_argument("--out", default=str(SPEAKER_FILE))
    args = ap.parse_args()
    ds = Beat2Dataset(args.data)
    if not ds.names:
        print(f"{args.data}: no motion takes found", file=sys.stderr)
        return 2
    refs = [speaker_statistics(t.motion, t.audio) for t in (ds.load(n, with_text=False) for n in ds.names)]
    w = np.array([r.seconds for r in refs])
    stats = {k: float(np.average([r.statistics[k] for r in refs], weights=w)) for k in refs[0].statistics}
    speed = np.average([r.mean_speed for r in refs], axis=0, weights=w)
    source = (f"the shipped speaker's training take{'s' if len(refs) > 1 else ''} {', '.join(ds.names)} "
              f"({w.sum():.0f} s, BEAT2), motion against its own speech")
    path = save_speaker_reference(SpeakerReference(stats, speed, source, float(w.sum())), args.out)
    print(f"wrote {path}")
    for k, v in stats.items():
        print(f"  {k}: {v:.4f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
