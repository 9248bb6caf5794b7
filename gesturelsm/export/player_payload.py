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
* payload: JSON the page hands to the player, built from what it shows (`Shown`: one `Slot` per method in page
  order, the speech's seconds, an edited method's motion before the edit): fps, frames, duration, joints, the
  speech's URL, the folder's name (`id`) and one entry per slot
    made        {label, method, body (GLB URL), motion (bin URL), expressions (E)}
    being made  the same of its motion so far, with partial: true and frames (how many it has)
    failed      {label, method, body (the rest body), motion: null, expressions: 0, error (why)}
    waiting     the same without error
  and, for an edit, compare {index, method, motion (bin URL of the motion before the edit)}.
"""
from __future__ import annotations

import hashlib
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from ..body.model import resolve_body
from ..constants import FPS
from ..motion.rotations import axis_angle_to_quaternion_xyzw as axis_angle_to_quaternion
from ..motion.rotations import continuous_quaternions
from ..motion.sequence import NUM_BETAS, MotionSequence
from ..motion.skeleton import NUM_JOINTS
from ..request_files import player_before, player_file, player_partial
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


@dataclass(frozen=True)
class Slot:
    """One method the player shows, in one of four states: made (`motion`, its finished motion), being made with its
    first windows decoded (`partial`, the raw motion so far), failed (`error`, why it has no motion), or nothing yet
    (none of them). Made wins over partial, partial over the error."""
    method: str
    label: str
    motion: MotionSequence | None = None
    partial: MotionSequence | None = None
    error: str | None = None


@dataclass(frozen=True)
class Shown:
    """What the player shows: its slots in page order, the speech's length in seconds (the frames while no method is
    made) and, for an edited result, the edited method with its motion before the edit (the player's A/B)."""
    slots: tuple[Slot, ...]
    seconds: float = 0.0
    before: tuple[str, MotionSequence] | None = None


@dataclass(frozen=True)
class PlayerFiles:
    """The names of the player's motion files in a folder, from the slot's index and method (default: the request
    folder's names, gesturelsm/request_files.py)."""
    made: Callable[[int, str], str] = player_file
    partial: Callable[[int, str, int], str] = player_partial            # and the frames made so far
    before: Callable[[int, str], str] = player_before


def rest_body(body, cache: str | Path) -> Path:
    """The rest body of the default shape (zero betas, what the generators output), written once into `cache`."""
    return body_glb(body, np.zeros(NUM_BETAS, np.float32), cache)


def _written(seq: MotionSequence, body, path: Path) -> int:
    """Write `seq`'s motion file unless it exists (the same motion: a payload made again); its E."""
    if path.exists():
        return len([e for e in used_expressions(body) if e < seq.expressions.shape[1]])
    return write_motion(seq, body, path)[1]


def player_payload(shown: Shown, body, out: str | Path, cache: str | Path, url: Callable[[Path], str],
                   audio: Path | None = None, files: PlayerFiles = PlayerFiles()) -> dict:
    """Write the motion files of `shown` into `out` (rest bodies into `cache`) and return the player's payload (the
    module docstring); `url(path)` turns a written file into the URL the browser fetches. The made motions are cut to
    the shortest of them; with none made the frames are the speech's. A file that exists already is the same motion
    (a request's payload made again as more of its methods are done) and is not written again."""
    body = resolve_body(body)
    out = Path(out)
    made = [s.motion for s in shown.slots if s.motion is not None]
    cut = min((m.num_frames for m in made), default=0)
    fps = made[0].fps if made else FPS
    frames = cut or int(round(shown.seconds * fps))
    bodies = []
    for i, s in enumerate(shown.slots):
        if s.motion is not None or s.partial is not None:
            seq = s.motion.slice(0, cut) if s.motion is not None else s.partial
            path = out / (files.made(i, s.method) if s.motion is not None
                          else files.partial(i, s.method, s.partial.num_frames))
            entry = {"label": s.label, "method": s.method, "body": url(body_glb(body, seq.betas, cache)),
                     "motion": url(path), "expressions": _written(seq, body, path)}
            bodies.append(entry if s.motion is not None else {**entry, "partial": True, "frames": seq.num_frames})
        else:
            bodies.append({"label": s.label, "method": s.method, "body": url(rest_body(body, cache)), "motion": None,
                           "expressions": 0, **({"error": s.error} if s.error is not None else {})})
    p = {"fps": fps, "frames": frames, "duration": frames / fps, "joints": NUM_JOINTS,
         "audio": url(audio) if audio else None, "bodies": bodies, "id": out.name}
    if shown.before is not None:
        method, seq = shown.before
        i = [s.method for s in shown.slots].index(method)
        path = out / files.before(i, method)
        _written(seq.slice(0, frames), body, path)
        p["compare"] = {"index": i, "method": method, "motion": url(path)}
    return p


__all__ = ["PlayerFiles", "Shown", "Slot", "axis_angle_to_quaternion", "body_glb", "motion_arrays", "motion_record",
           "player_payload", "read_motion", "rest_body", "used_expressions", "write_motion"]
