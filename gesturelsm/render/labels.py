"""Text labels drawn into frames with PIL (pillow comes with imageio).

Font: DejaVu Sans from the system when present (Debian: fonts-dejavu-core), else pillow's built-in
scalable font (pillow >= 10.1), else pillow's bitmap font. Nothing is downloaded.
Each label is drawn once into a small RGBA patch; frames get it by alpha blending that patch.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np

_FONT_DIRS = ("/usr/share/fonts/truetype/dejavu", "/usr/share/fonts/TTF", "/usr/share/fonts/dejavu",
              "/Library/Fonts", "C:/Windows/Fonts")


@lru_cache(maxsize=16)
def load_font(px: int, bold: bool = False):
    from PIL import ImageFont

    name = "DejaVuSans-Bold.ttf" if bold else "DejaVuSans.ttf"
    for d in _FONT_DIRS:
        p = Path(d) / name
        if p.exists():
            try:
                return ImageFont.truetype(str(p), px)
            except OSError:
                pass
    try:
        return ImageFont.load_default(size=px)      # pillow >= 10.1 (FreeType)
    except TypeError:
        return ImageFont.load_default()


@dataclass
class LabelPatch:
    rgba: np.ndarray          # (h, w, 4) uint8
    x: int                    # top-left position inside the frame
    y: int

    def blend_into(self, frame: np.ndarray, x_offset: int = 0) -> None:
        """Alpha-blend the patch into frame (H, W, 3) uint8 in place."""
        h, w = self.rgba.shape[:2]
        x0, y0 = self.x + x_offset, self.y
        x1, y1 = min(x0 + w, frame.shape[1]), min(y0 + h, frame.shape[0])
        if x1 <= x0 or y1 <= y0:
            return
        p = self.rgba[: y1 - y0, : x1 - x0]
        a = p[..., 3:4].astype(np.float32) / 255.0
        region = frame[y0:y1, x0:x1].astype(np.float32)
        frame[y0:y1, x0:x1] = np.round(region + a * (p[..., :3].astype(np.float32) - region)).astype(np.uint8)


def _fit(text: str, font, max_w: int, draw) -> str:
    if draw.textlength(text, font=font) <= max_w:
        return text
    while text and draw.textlength(text + "…", font=font) > max_w:
        text = text[:-1]
    return text + "…"


def make_label(lines: list[str], tile_width: int, px: int, dark_background: bool = False) -> LabelPatch | None:
    """A rounded box with the lines (the first in bold) for the top-left corner of a tile."""
    lines = [s for s in (str(s).strip() for s in lines) if s]
    if not lines:
        return None
    from PIL import Image, ImageDraw

    fonts = [load_font(px, bold=True)] + [load_font(max(8, int(px * 0.82)))] * (len(lines) - 1)
    pad, gap, margin = max(3, px // 3), max(2, px // 5), max(4, px // 2)
    max_text = tile_width - 2 * margin - 2 * pad
    probe = ImageDraw.Draw(Image.new("RGBA", (1, 1)))
    lines = [_fit(s, f, max_text, probe) for s, f in zip(lines, fonts)]
    boxes = [probe.textbbox((0, 0), s, font=f) for s, f in zip(lines, fonts)]
    heights = [max(b[3], int(f.size if hasattr(f, "size") else px)) for b, f in zip(boxes, fonts)]
    w = int(max(b[2] for b in boxes)) + 2 * pad
    h = int(sum(heights) + gap * (len(lines) - 1)) + 2 * pad
    img = Image.new("RGBA", (w, h), (0, 0, 0, 0))
    d = ImageDraw.Draw(img)
    if dark_background:
        box, ink = (20, 22, 26, 190), (245, 245, 245, 255)
    else:
        box, ink = (255, 255, 255, 205), (25, 27, 31, 255)
    d.rounded_rectangle((0, 0, w - 1, h - 1), radius=max(2, pad), fill=box)
    y = pad
    for s, f, hh in zip(lines, fonts, heights):
        d.text((pad, y), s, font=f, fill=ink if f is fonts[0] else ink[:3] + (215,))
        y += hh + gap
    return LabelPatch(np.asarray(img, np.uint8).copy(), margin, margin)


def label_lines(label: str | None, gen_seconds: float | None) -> list[str]:
    """'GestureLSM 8 steps' + 'generated in 0.42 s' (a label may hold several lines separated by '|' or '\\n')."""
    lines = [s for s in str(label or "").replace("|", "\n").split("\n")]
    if gen_seconds is not None:
        lines.append(f"generated in {gen_seconds:.2f} s")
    return lines
