"""Speed of `gesturelsm.retarget`: 60 s of motion (1800 frames at 30 fps) onto characters (markdown table out).

    .venv/bin/python benchmarks/retarget_speed.py [--seconds 60] [--repeats 5] [--threads 1]

Motion: the real BEAT2 take from ../shared, repeated to the length asked (smooth random motion when the take is
absent). Characters: cryptovoxels.vrm (../shared, VRM 0.x, 43 humanoid bones of 58 joints) and skeletons built
from the SMPL-X rest pose (all 52 body and finger bones; an A-pose Z-up centimetre rig without fingers). Times
are the retargeting alone (SMPL-X forward kinematics + solving + local rotations), median of the repeats, after
one warm-up run, and beside them the grounding of the result on the character's own legs (retarget/grounding.py:
contacts, plants, two-bone IK, the legs' local rotations again); loading the character and writing files are not
included. Wall seconds depend on what else runs on the machine; CPU seconds (this process's) much less, so both are
printed. Compare rows of one run.
"""
from __future__ import annotations

from _harness import SHARED

import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "tests"))

from _rigs import Y_UP_TO_Z_UP, build_rig  # noqa: E402
from gesturelsm.body.model import resolve_body  # noqa: E402
from _motion import length_args, looped_motion  # noqa: E402
from gesturelsm.retarget import SourceBody, load_character, retarget  # noqa: E402
from gesturelsm.retarget.grounding import ground_retargeted  # noqa: E402
from gesturelsm.retarget.solve import prepare  # noqa: E402

VRM = SHARED / "assets" / "characters" / "cryptovoxels.vrm"


def main() -> None:
    args = length_args(__doc__.split("\n")[0])
    seq, kind = looped_motion(args.seconds, 0.3)
    source = SourceBody.of(resolve_body(None), seq.betas)
    rigs = []
    if VRM.exists():
        rigs.append(("cryptovoxels.vrm", load_character(VRM).skeleton))
    rigs.append(("built T-pose, fingers", build_rig(source.rest_joints)[0]))
    rigs.append(("built A-pose Z-up cm, no fingers",
                 build_rig(source.rest_joints, apose=40, world=Y_UP_TO_Z_UP, units=100, fingers=False)[0]))
    print(f"{seq.num_frames} frames ({seq.duration:.0f} s, {kind}), torch threads {args.threads}, "
          f"median of {args.repeats}\n")
    print("| character | joints | humanoid bones | wall s | CPU s | frames per wall second | + feet on its own legs: "
          "wall s / CPU s |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    for name, skel in rigs:
        setup = prepare(skel, source)
        result = retarget(seq, skel, source, setup=setup)                      # warm-up
        ground_retargeted(result, setup)
        wall, cpu, g_wall, g_cpu = [], [], [], []
        for _ in range(args.repeats):
            t0, c0 = time.perf_counter(), time.process_time()
            result = retarget(seq, skel, source)
            wall.append(time.perf_counter() - t0)
            cpu.append(time.process_time() - c0)
            t0, c0 = time.perf_counter(), time.process_time()
            ground_retargeted(result, setup)
            g_wall.append(time.perf_counter() - t0)
            g_cpu.append(time.process_time() - c0)
        med = float(np.median(wall))
        print(f"| {name} | {len(skel)} | {len(skel.bones)} | {med:.3f} | {float(np.median(cpu)):.3f} | "
              f"{seq.num_frames / med:,.0f} | {np.median(g_wall):.3f} / {np.median(g_cpu):.3f} |")


if __name__ == "__main__":
    main()
