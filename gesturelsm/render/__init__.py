"""Offscreen rendering of SMPL-X motion to frames and browser-playable videos with the speech.

    from gesturelsm.render import render_video, render_frames, RenderStyle
    render_video([seq], "speech.wav", "out.mp4")                                  # one body, 512 x 512
    render_video([a, b, gt], audio, "cmp.mp4", labels=["GestureLSM 8 steps", "DDIM 20", "ground truth"],
                 gen_seconds=[0.4, 2.1, None])                                   # side by side, 1536 x 512
    frames = render_frames([seq], frame_indices=[0, 15])                           # (2, 512, 512, 3) uint8
    render_video([seq], "speech.wav", "avatar.mp4", character=load_character("avatar.vrm"))  # its own mesh

Importing this package loads no OpenGL but already chooses the backend (OSMesa or EGL, see `backend.py`)
by setting PYOPENGL_PLATFORM, so code that imports pyrender afterwards gets an offscreen context too; if
no backend works, the error comes with the first render. Frames are 30 fps; frame k shows motion frame k
at time k / 30 s.
"""
from .backend import RenderError, select_platform
from .camera import Camera
from .frames import RenderWarning, clip_layout, fit_camera, iter_frames, prepare_motions, render_frames, resolve_body
from .style import STYLES, RenderStyle, parse_color, parse_size
from .video import prepare_audio, render_video

try:
    select_platform()
except RenderError:  # reported, with the missing library named, when something is rendered
    pass

__all__ = ["Camera", "RenderError", "RenderStyle", "RenderWarning", "STYLES", "clip_layout", "fit_camera",
           "iter_frames", "parse_color", "parse_size", "prepare_audio", "prepare_motions", "render_frames",
           "render_video", "resolve_body", "select_platform"]
