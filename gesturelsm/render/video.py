"""Frames + speech -> an mp4 that plays in a browser: H.264 (libx264, yuv420p) + AAC, +faststart.

Encoding uses the ffmpeg binary bundled with imageio-ffmpeg (no system ffmpeg). Frames are piped to one
ffmpeg process as they are rendered, together with the speech written to a temporary WAV that was trimmed
or zero-padded to exactly the motion's length, so the two streams start together (video frame 0 and audio
sample 0 are time 0) and end together (duration = frames / 30 s; AAC frames may add < 64 ms of silence).
The file is written next to `out` under a temporary name and renamed when complete.
"""
from __future__ import annotations

import itertools
import os
import tempfile
import time
import warnings
from pathlib import Path
from typing import Sequence

import numpy as np

from ..audio import SAMPLE_RATE, AudioError, load_audio, to_mono
from ..constants import FPS, Progress
from ..errors import InputError
from .camera import Camera
from .frames import MotionLike, RenderWarning, iter_frames, prepare_motions
from .style import RenderStyle

AudioLike = np.ndarray | str | Path | None


def prepare_audio(audio: AudioLike, num_frames: int, sr: int = SAMPLE_RATE, fps: int = FPS) -> np.ndarray | None:
    """Speech (array at `sr`, or a file path) -> float32 mono of exactly num_frames / fps seconds."""
    if audio is None:
        return None
    if isinstance(audio, (str, Path)):
        y = load_audio(audio, sr)                   # AudioError with a clear message
        name = Path(audio).name
    else:
        y = np.asarray(audio)
        name = "the audio"
        if y.ndim not in (1, 2) or y.size == 0:
            raise AudioError(f"{name}: expected a 1-D array of samples, got shape {y.shape}")
        y = to_mono(y)
        if not np.isfinite(y).all():
            raise AudioError(f"{name} contains NaN or infinite samples")
    if sr <= 0:
        raise AudioError(f"sample rate must be positive, got {sr}")
    n = int(round(num_frames / fps * sr))
    diff = (len(y) - n) / sr
    if abs(diff) > 0.5:
        what = "trimmed" if diff > 0 else "padded with silence"
        warnings.warn(f"{name} lasts {len(y) / sr:.2f} s, the motion {num_frames / fps:.2f} s: audio {what} to "
                      "the motion's length", RenderWarning, stacklevel=3)
    if len(y) >= n:
        return np.ascontiguousarray(y[:n], np.float32)
    return np.concatenate([y, np.zeros(n - len(y), np.float32)]).astype(np.float32)


def render_video(motions: Sequence[MotionLike] | MotionLike, audio: AudioLike, out: str | Path,
                 labels: Sequence[str] | None = None, size: tuple[int, int] | None = None, body=None,
                 progress: Progress | None = None, *, style: RenderStyle | None = None, sr: int = SAMPLE_RATE,
                 gen_seconds: Sequence[float | None] | None = None, camera: Camera | None = None,
                 crf: int = 20, preset: str = "veryfast", character=None, grounding: bool = True) -> Path:
    """Render motions (side by side when several) with the speech into `out` (.mp4); returns the path.

    audio: samples at `sr` (16 kHz), a file path, or None for a silent video. It is trimmed / padded to the
    motion (a RenderWarning when they differ by more than 0.5 s). labels / gen_seconds: one per motion,
    drawn in each tile's top-left corner. size: one tile's (width, height), default 512 x 512.
    progress(fraction, message) is called every few frames. character: a retarget.Character whose own mesh is
    drawn instead of the body, its feet on its own legs unless `grounding` is off (see `iter_frames`).
    """
    import imageio_ffmpeg
    import soundfile as sf

    out = Path(out)
    if out.suffix.lower() != ".mp4":
        raise InputError(f"{out}: the output must be an .mp4 file")
    style = (style or RenderStyle()).with_size(size)
    seqs = prepare_motions(motions)
    T = seqs[0].num_frames
    y = prepare_audio(audio, T, sr)
    out.parent.mkdir(parents=True, exist_ok=True)
    W, H = style.width * len(seqs), style.height
    t0 = time.perf_counter()
    frames = iter_frames(seqs, body=body, style=style, labels=labels, gen_seconds=gen_seconds, camera=camera,
                         character=character, grounding=grounding)
    try:
        first = next(frames)          # a figure that cannot be drawn stops here, before the encoder starts
        with tempfile.TemporaryDirectory(prefix="gesturelsm-render-") as tmp:
            wav = None
            if y is not None:
                wav = os.path.join(tmp, "speech.wav")
                sf.write(wav, y, sr, subtype="PCM_16")
            part = out.with_name(f".{out.stem}.part{os.getpid()}.mp4")
            params = ["-preset", preset, "-crf", str(int(crf)), "-movflags", "+faststart"]
            if wav is not None:
                params += ["-b:a", "128k"]
            writer = imageio_ffmpeg.write_frames(str(part), (W, H), fps=FPS, codec="libx264", pix_fmt_out="yuv420p",
                                                 quality=None, macro_block_size=2, ffmpeg_log_level="error",
                                                 output_params=params, audio_path=wav,
                                                 audio_codec="aac" if wav else None)
            try:
                writer.send(None)
                step = max(1, T // 100)
                for i, frame in enumerate(itertools.chain([first], frames)):
                    writer.send(frame)
                    if progress is not None and (i % step == 0 or i == T - 1):
                        el = time.perf_counter() - t0
                        progress((i + 1) / T, f"frame {i + 1}/{T} ({(i + 1) / max(el, 1e-9):.1f} fps)")
                writer.close()
            except BaseException:
                writer.close()
                part.unlink(missing_ok=True)
                raise
            os.replace(part, out)
    finally:
        frames.close()
    return out
