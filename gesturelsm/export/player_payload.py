"""What the page's in-browser player (gesturelsm/webapp/player/src/player.js) loads: one rest body per shape, and a
compact binary motion per method, so the bodies move seconds before the server-side mp4 exists.

* body: a skinned GLB of the unposed body (`export_glb` of one rest frame): mesh, 55-joint skeleton, skin
  weights and expression morph targets. Written once per body shape (betas) into a cache folder and reused
  by every request; the browser caches it by URL as well.
* motion (`.bin`): one record of the binary motion format (export/motion_codec.py, kind quaternion, 30 fps,
  metres, y up, the body faces +z), frames t = 0..T-1:
    rotations   (T, 55, 4)  each joint's local rotation, unit quaternion x, y, z, w (the pose plus the body
                            model's pose mean, exactly what `export_glb` animates; sign-continuous over time)
    root        (T, 3)      pelvis position = rest pelvis + trans (the GLB's node-0 translation)
    expressions (T, E)      morph-target weights, E = the body GLB's used expression directions (often 0)
  The live feed (gesturelsm/webapp/live.py) sends the same records, a chunk of frames each.
* payload: JSON the page hands to the player: fps, frames, duration, the speech's URL and one entry per body
  {label, method, body (GLB URL), motion (bin URL), expressions (E)}.
"""
from __future__ import annotations

import hashlib
import os
from pathlib import Path
from typing import Callable, Sequence

import numpy as np

from ..body.model import resolve_body
from ..constants import FPS
from ..motion.rotations import axis_angle_to_quaternion_xyzw as axis_angle_to_quaternion
from ..motion.rotations import continuous_quaternions
from ..motion.sequence import MotionSequence
from ..motion.skeleton import NUM_JOINTS
from .glb import export_glb
from .motion_codec import MotionRecord, decode, encode
from .skeleton import full_poses

MAX_EXPRESSIONS = 10            # as export_glb's default: morph targets carried by the body GLB


def used_expressions(body, max_expressions: int = MAX_EXPRESSIONS) -> list[int]:
    """Expression directions the body GLB carries as morph targets (the non-zero ones among the first few)."""
    E = min(int(body.num_expressions), int(max_expressions))
    if E <= 0:
        return []
    dirs = body.module.expr_dirs.detach().cpu().numpy()[..., :E]
    return [e for e in range(E) if np.abs(dirs[..., e]).max() > 0]


def motion_arrays(seq: MotionSequence, body) -> dict[str, np.ndarray]:
    """The player's arrays for `seq` on `body`: rotations (T, 55, 4), root (T, 3), expressions (T, E)."""
    T = seq.num_frames
    quats = continuous_quaternions(axis_angle_to_quaternion(full_poses(seq, body).reshape(T, NUM_JOINTS, 3)))
    quats = quats.astype(np.float32)                                                       # (T, 55, 4)
    pelvis = body.rest_joints(seq.betas).astype(np.float64)[0]                             # (3,)
    root = (seq.trans.astype(np.float64) + pelvis).astype(np.float32)                      # (T, 3)
    used = [e for e in used_expressions(body) if e < seq.expressions.shape[1]]
    expr = seq.expressions[:, used].astype(np.float32) if used else np.zeros((T, 0), np.float32)
    return {"rotations": quats, "root": root, "expressions": expr}



def motion_record(seq: MotionSequence, body, start: int = 0, meta: dict | None = None) -> MotionRecord:
    """`seq` on `body` as the player's record (kind quaternion), its first frame numbered `start`."""
    a = motion_arrays(seq, body)
    return MotionRecord(a["rotations"], a["root"], a["expressions"], fps=seq.fps, start=start, meta=meta or {})


def write_motion(seq: MotionSequence, body, path: str | Path) -> tuple[Path, int]:
    """Write the motion `.bin` (layout in the module docstring); returns the path and E."""
    record = motion_record(seq, body)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(encode(record))
    return path, record.expressions.shape[1]


def read_motion(path: str | Path) -> MotionRecord:
    """Inverse of `write_motion` (tests, tools); a `MotionFormatError` naming the file when it is not one."""
    return decode(Path(path).read_bytes(), source=str(path))


def body_glb(body, betas: np.ndarray | None, cache: str | Path) -> Path:
    """The rest body as a skinned GLB in `cache`, written once per shape (file name = hash of the betas)."""
    body = resolve_body(body)
    betas = np.zeros(0, np.float32) if betas is None else np.asarray(betas, np.float32).reshape(-1)
    template = body.module.v_template.detach().cpu().numpy().astype(np.float32)
    key = hashlib.sha1(np.round(betas, 5).tobytes() + template.tobytes()).hexdigest()[:12]
    path = Path(cache) / f"body-{key}.glb"
    if not path.exists():
        rest = MotionSequence(poses=np.zeros((1, NUM_JOINTS * 3), np.float32), trans=np.zeros((1, 3), np.float32),
                              betas=betas, expressions=np.zeros((1, max(1, int(body.num_expressions))), np.float32))
        tmp = path.with_name(f".{path.stem}.{os.getpid()}.glb")
        export_glb(rest, tmp, body=body, max_expressions=MAX_EXPRESSIONS)
        os.replace(tmp, path)                   # complete files only: concurrent requests may read it
    return path


def player_payload(motions: Sequence[MotionSequence], labels: Sequence[str], methods: Sequence[str], body,
                   out: str | Path, cache: str | Path, url: Callable[[Path], str],
                   audio: Path | None = None, names: Sequence[str] | None = None) -> dict:
    """Write each motion's `.bin` into `out` (rest bodies into `cache`) and return the player's payload;
    `url(path)` turns a written file into the URL the browser fetches. `names`: the motion files' names (default
    player-I-METHOD.bin); a file that exists already is the same motion (a request's payload made again as more of
    its methods are done) and is not written again."""
    body = resolve_body(body)
    out = Path(out)
    frames = min((m.num_frames for m in motions), default=0)
    fps = motions[0].fps if motions else FPS
    bodies = []
    for i, (seq, label, method) in enumerate(zip(motions, labels, methods)):
        seq = seq.slice(0, frames)
        path = out / (names[i] if names else f"player-{i}-{method}.bin")
        if path.exists():
            E = len([e for e in used_expressions(body) if e < seq.expressions.shape[1]])
        else:
            path, E = write_motion(seq, body, path)
        bodies.append({"label": label, "method": method, "body": url(body_glb(body, seq.betas, cache)),
                       "motion": url(path), "expressions": E})
    return {"fps": fps, "frames": frames, "duration": frames / fps, "joints": NUM_JOINTS,
            "audio": url(audio) if audio else None, "bodies": bodies, "id": out.name}


__all__ = ["axis_angle_to_quaternion", "body_glb", "motion_arrays", "motion_record", "player_payload", "read_motion",
           "used_expressions", "write_motion"]
