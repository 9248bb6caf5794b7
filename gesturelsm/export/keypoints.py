"""2D keypoints per frame in OpenPose's JSON layout, projected through the render camera.

For image-animation tools (ControlNet OpenPose, pose-guided video models) that take OpenPose skeletons.
Each frame: `{"version": 1.3, "people": [{"pose_keypoints_2d": [x, y, c] * 25, "hand_left_keypoints_2d":
[x, y, c] * 21, "hand_right_keypoints_2d": [x, y, c] * 21, "face_keypoints_2d": [x, y, c] * 70}],
"canvas_width": W, "canvas_height": H}` (the canvas keys are what ControlNet's pose editor reads).
Pixels: x right, y down, origin at the image's top-left corner (see `render/camera.py`). c = 1 for a point
in front of the camera and inside the image, else the point is written as 0, 0, 0 (OpenPose's "not found").

Files: `path` ending in .json -> one file with every frame (`{"fps", "canvas_width", "canvas_height",
"camera", "frames": [frame, ...]}`); any other path -> a folder with one OpenPose file per frame,
`<stem>_<frame:012d>_keypoints.json` (OpenPose's own naming), frame 0 = time 0, 30 fps.

The camera is the one `render_video` uses for this motion alone at `size` and `style`, without labels (what
`gesturelsm render MOTION.npz` makes); pass `camera=gesturelsm.render.fit_camera(motions, labels=...)` to
match a side-by-side or labelled video. So keypoints land on the rendered body.

Mapping from SMPL-X (the SMPLify-X convention; `extra` = smplx's vertex joints of the body model):
BODY_25  0 nose(extra) 1 neck 2 R shoulder 3 R elbow 4 R wrist 5 L shoulder 6 L elbow 7 L wrist 8 pelvis
         9 R hip 10 R knee 11 R ankle 12 L hip 13 L knee 14 L ankle 15 R eye 16 L eye 17 R ear 18 L ear
         19 L big toe 20 L small toe 21 L heel 22 R big toe 23 R small toe 24 R heel (15-24: extra)
hand 21  0 wrist, then thumb 1-3 + tip, index 1-3 + tip, middle, ring, pinky (tips: extra finger-tip vertices)
face 70  17-67 = the body model's 51 landmarks (iBUG 17-67: brows, nose, eyes, lips); 68 / 69 = right / left
         eyeball centre (pupil); the jaw contour 0-16 is not in SMPL-X's static landmarks: written as missing.
"""
from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Iterator

import numpy as np

from ..body.model import resolve_body
from ..motion.sequence import MotionSequence
from ..motion.skeleton import JOINT_INDEX, NUM_JOINTS
from ..render.frames import fit_camera
from .guard import check_motion, finite
from .skeleton import EXTRA_NAMES, extra_vertex_ids

_X = {n: NUM_JOINTS + i for i, n in enumerate(EXTRA_NAMES)}      # index into [joints | extra]
J = JOINT_INDEX
BODY_25 = [_X["nose"], J["neck"], J["right_shoulder"], J["right_elbow"], J["right_wrist"], J["left_shoulder"],
           J["left_elbow"], J["left_wrist"], J["pelvis"], J["right_hip"], J["right_knee"], J["right_ankle"],
           J["left_hip"], J["left_knee"], J["left_ankle"], _X["reye"], _X["leye"], _X["rear"], _X["lear"],
           _X["LBigToe"], _X["LSmallToe"], _X["LHeel"], _X["RBigToe"], _X["RSmallToe"], _X["RHeel"]]


def _hand(side: str) -> list[int]:
    s, c = side, side[0]
    out = [J[f"{s}_wrist"]]
    for f in ("thumb", "index", "middle", "ring", "pinky"):
        out += [J[f"{s}_{f}1"], J[f"{s}_{f}2"], J[f"{s}_{f}3"], _X[f"{c}{f}"]]
    return out


HAND_LEFT, HAND_RIGHT = _hand("left"), _hand("right")
assert len(BODY_25) == 25 and len(HAND_LEFT) == 21


# frames whose keypoints export_keypoints holds at once (about 4 MB of them); a multiple of keypoints_3d's body
# batch (128), so the streamed numbers are those of keypoints_2d over the whole motion, bit for bit
STREAM_FRAMES = 1024


def _keypoints_3d_chunks(seq: MotionSequence, body, chunk: int = 128) -> Iterator[dict[str, np.ndarray]]:
    """keypoints_3d of frames [s, s + chunk) for s = 0, chunk, 2 chunk, ... (`body` resolved)."""
    ids = extra_vertex_ids(body)
    lmk_f = body.module.lmk_faces_idx.cpu().numpy().astype(np.int64)
    lmk_b = body.module.lmk_bary_coords.cpu().numpy().astype(np.float64)             # (51, 3)
    tri = body.faces[lmk_f]                                                            # (51, 3)
    T = seq.num_frames
    for s in range(0, T, chunk):
        e = min(T, s + chunk)
        o = body.forward(seq.poses[s:e], seq.trans[s:e], seq.expressions[s:e], seq.betas)
        v = o.vertices.astype(np.float64)
        allj = np.concatenate([o.joints.astype(np.float64), v[:, ids]], 1)           # (B, 55 + 21, 3)
        out = {"body": allj[:, BODY_25], "hand_left": allj[:, HAND_LEFT], "hand_right": allj[:, HAND_RIGHT],
               "face": np.full((e - s, 70, 3), np.nan)}
        if len(lmk_f) == 51:
            out["face"][:, 17:68] = np.einsum("bkcx,kc->bkx", v[:, tri], lmk_b)
        out["face"][:, 68] = allj[:, J["right_eye_smplhf"]]
        out["face"][:, 69] = allj[:, J["left_eye_smplhf"]]
        yield out


def keypoints_3d(seq: MotionSequence, body=None, chunk: int = 128) -> dict[str, np.ndarray]:
    """World-space keypoints (T, K, 3) in the OpenPose layouts: body (25), hand_left / hand_right (21),
    face (70; NaN where SMPL-X has no point)."""
    parts = list(_keypoints_3d_chunks(seq, resolve_body(body), chunk))
    return {k: np.concatenate([p[k] for p in parts]) for k in ("body", "hand_left", "hand_right", "face")}


def _project(pts: dict[str, np.ndarray], camera) -> dict[str, np.ndarray]:
    out = {}
    for k, p in pts.items():
        finite = np.isfinite(p).all(-1)
        q = np.where(finite[..., None], p, 0.0)
        xy = camera.project(q)
        depth = -camera.to_camera(q)[..., 2]
        ok = finite & (depth > camera.znear) & (xy[..., 0] >= 0) & (xy[..., 0] < camera.width) \
            & (xy[..., 1] >= 0) & (xy[..., 1] < camera.height)
        out[k] = np.where(ok[..., None], np.concatenate([xy, np.ones_like(xy[..., :1])], -1), 0.0)
    return out


def keypoints_2d(seq: MotionSequence, camera=None, size: tuple[int, int] = (512, 512), body=None, style=None
                 ) -> tuple[dict[str, np.ndarray], object]:
    """({layout: (T, K, 3) [x, y, c]}, camera): projected keypoints; missing / outside points are 0, 0, 0.
    camera None: the one `render_video([seq], ..., style=style)` uses at `size` (no labels)."""
    if camera is None:
        camera = fit_camera([seq], body=body, style=style, size=size)
    return _project(keypoints_3d(seq, body), camera), camera


def keypoints_2d_chunks(seq: MotionSequence, camera, body=None, chunk: int = STREAM_FRAMES
                        ) -> Iterator[dict[str, np.ndarray]]:
    """keypoints_2d through `camera`, `chunk` frames at a time (the same numbers): memory bounded by the chunk
    whatever the motion's length."""
    body = resolve_body(body)
    for s in range(0, seq.num_frames, chunk):
        yield _project(keypoints_3d(seq.slice(s, min(seq.num_frames, s + chunk)), body), camera)


def _frame_dict(kp: dict[str, np.ndarray], t: int, W: int, H: int) -> dict:
    def flat(a: np.ndarray) -> list[float]:
        return [round(float(x), 2) for x in a.reshape(-1)]

    return {"version": 1.3, "people": [{
        "person_id": [-1],
        "pose_keypoints_2d": flat(kp["body"][t]), "face_keypoints_2d": flat(kp["face"][t]),
        "hand_left_keypoints_2d": flat(kp["hand_left"][t]), "hand_right_keypoints_2d": flat(kp["hand_right"][t]),
        "pose_keypoints_3d": [], "face_keypoints_3d": [], "hand_left_keypoints_3d": [], "hand_right_keypoints_3d": []}],
        "canvas_width": W, "canvas_height": H}


def export_keypoints(seq: MotionSequence, path: str | Path, camera=None, size: tuple[int, int] = (512, 512),
                     body=None, style=None) -> Path:
    """Write OpenPose-style 2D keypoints (see the module docstring); returns the file or folder path.

    Streamed: the keypoints are made, checked and written STREAM_FRAMES frames at a time, so memory does not grow
    with the motion's length (an hour: 108,000 frames). A problem part way (a non-finite keypoint) removes what was
    written: FILE.json is written under a temporary name and renamed when whole; a folder's files are removed."""
    check_motion(seq)
    body = resolve_body(body)
    cam = camera if camera is not None else fit_camera([seq], body=body, style=style, size=size)
    W, H = cam.width, cam.height
    path = Path(path)

    def frames() -> Iterator[str]:
        for kp in keypoints_2d_chunks(seq, cam, body):
            for k, v in kp.items():
                finite(v, f"the {k.replace('_', ' ')} keypoints")
            for t in range(len(kp["body"])):
                yield json.dumps(_frame_dict(kp, t, W, H), separators=(",", ":"))

    if path.suffix.lower() == ".json":
        path.parent.mkdir(parents=True, exist_ok=True)
        doc = {"format": "openpose-1.3 per frame", "fps": seq.fps, "canvas_width": W, "canvas_height": H,
               "camera": {"eye": list(cam.eye), "target": list(cam.target), "yfov": cam.yfov,
                          "intrinsics": cam.intrinsics.tolist()}}
        part = path.with_name(f".{path.name}.part")
        try:
            with open(part, "w") as fh:
                fh.write(json.dumps(doc, separators=(",", ":"))[:-1] + ',"frames":[')
                for t, fr in enumerate(frames()):
                    fh.write("," * (t > 0) + fr)
                fh.write("]}")
            os.replace(part, path)
        finally:
            part.unlink(missing_ok=True)
        return path
    made = not path.exists()
    path.mkdir(parents=True, exist_ok=True)
    written: list[Path] = []
    try:
        for t, fr in enumerate(frames()):
            f = path / f"{path.name}_{t:012d}_keypoints.json"
            written.append(f)
            f.write_text(fr)
    except BaseException:
        for f in written:
            f.unlink(missing_ok=True)
        if made:
            path.rmdir()
        raise
    return path
