"""Cost of the ARKit face export (`gesturelsm export --arkit`) for 60 s of motion (1800 frames at 30 fps); markdown
table out.

    .venv/bin/python benchmarks/arkit_speed.py [--seconds 60] [--repeats 5] [--threads 1]

Motion: the real BEAT2 take from ../shared (its jaw, expressions, head and eyes move), repeated to the length asked;
smooth random motion when the take is absent. Body: the built-in mannequin (or $GESTURELSM_SMPLX_MODEL). Rows:
measuring the face (`arkit_face`: facial landmarks for the jaw alone and for jaw + expressions, head and eye
rotations), writing the Live Link Face CSV, reading it back, and the BVH export of the same motion for scale. Median
of the repeats after one warm-up run; wall and this process's CPU seconds (the machine may be shared: compare rows
of one run).
"""
from __future__ import annotations

from _harness import timed as harness_timed

import sys
import tempfile
from pathlib import Path


REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from gesturelsm.body.model import resolve_body  # noqa: E402
from gesturelsm.export import arkit_face, export_bvh, read_live_link_csv  # noqa: E402
from gesturelsm.export.live_link import write_live_link_csv  # noqa: E402
from _motion import length_args, looped_motion  # noqa: E402


def timed(fn, repeats: int) -> tuple[float, float]:
    t = harness_timed(fn, repeats, warmup=1)
    return t.median, t.cpu_median


def main() -> None:
    args = length_args(__doc__.split("\n")[0])
    seq, kind = looped_motion(args.seconds)
    body = resolve_body(None)
    face = arkit_face(seq, body)
    with tempfile.TemporaryDirectory() as tmp:
        csv = Path(tmp) / "face.csv"
        write_live_link_csv(face, csv)
        rows = [("measure the face (arkit_face)", timed(lambda: arkit_face(seq, body), args.repeats)),
                ("write the Live Link Face CSV", timed(lambda: write_live_link_csv(face, csv), args.repeats)),
                ("read it back (read_live_link_csv)", timed(lambda: read_live_link_csv(csv), args.repeats)),
                ("BVH export, same motion (scale)", timed(lambda: export_bvh(seq, Path(tmp) / "m.bvh", body=body),
                                                          args.repeats))]
        size = csv.stat().st_size
    print(f"{seq.num_frames} frames ({kind}, {args.seconds:g} s), body {body.path.name}, torch threads "
          f"{args.threads}, CSV {size / 1e6:.2f} MB, median of {args.repeats}\n")
    print("| step | wall s | CPU s | ms per frame (wall) |\n|---|---|---|---|")
    for name, (w, c) in rows:
        print(f"| {name} | {w:.3f} | {c:.3f} | {1000 * w / seq.num_frames:.3f} |")


if __name__ == "__main__":
    main()
