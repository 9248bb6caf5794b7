"""`RenderStyle`: how a rendered frame looks (size, colours, floor, lights, framing). Frozen; presets below.

Colours are sRGB in [0, 1] (as a colour picker shows them) or '#rrggbb' strings; lights are pyrender
intensities. `size` is one body's tile: a side-by-side of N bodies is (N * width) x height pixels.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

from ..errors import InputError

Color = tuple[float, float, float]


def parse_color(value: str | Color | list[float]) -> Color:
    """'#rrggbb', 'rrggbb', 'r,g,b' (0-1 or 0-255) or a 3-tuple -> (r, g, b) floats in [0, 1]."""
    if isinstance(value, str):
        s = value.strip().lstrip("#")
        if len(s) == 6 and all(c in "0123456789abcdefABCDEF" for c in s):
            return tuple(int(s[i:i + 2], 16) / 255.0 for i in (0, 2, 4))  # type: ignore[return-value]
        try:
            parts = [float(p) for p in s.split(",")]
        except ValueError:
            parts = []
        if len(parts) != 3:
            raise InputError(f"colour {value!r}: use '#rrggbb' or 'r,g,b'")
        value = parts
    c = [float(x) for x in value]
    if len(c) != 3:
        raise InputError(f"colour {value!r} must have 3 components")
    if max(c) > 1.0:
        c = [x / 255.0 for x in c]
    if min(c) < 0.0 or max(c) > 1.0:
        raise InputError(f"colour {value!r} out of range")
    return (c[0], c[1], c[2])


@dataclass(frozen=True)
class RenderStyle:
    size: tuple[int, int] = (512, 512)          # (width, height) of one body's tile, pixels, even
    background: Color = (0.965, 0.965, 0.955)   # sRGB
    floor: str = "grid"                         # "grid" | "plain" | "none"
    floor_color: Color = (0.885, 0.885, 0.875)
    grid_color: Color = (0.76, 0.76, 0.75)
    grid_spacing: float = 0.5                   # metres between grid lines
    shadow: bool = True                         # soft contact shadow under each body
    body_color: Color = (0.78, 0.69, 0.60)      # clay
    body_roughness: float = 0.6
    key_light: float = 4.0                      # from the viewer's upper left
    fill_light: float = 1.0                     # from the viewer's right, lower
    rim_light: float = 2.0                      # from behind and above (separates body and background)
    ambient: float = 0.20
    yfov_deg: float = 28.0                      # vertical field of view
    elevation_deg: float = 7.0                  # camera looks down this much
    margin: float = 0.05                        # free border, fraction of the half-frame
    framing: str = "full"                       # "full" body (feet to raised hands) | "upper" (hips up)
    label_px: int = 0                           # label font size in pixels; 0 = automatic (height / 30)
    supersample: int = 1                        # render k times larger and average down (antialiasing)

    def __post_init__(self) -> None:
        w, h = (int(v) for v in self.size)
        if w < 32 or h < 32 or w % 2 or h % 2 or w > 4096 or h > 4096:
            raise InputError(f"render size {w}x{h}: width and height must be even, 32..4096 "
                             "(multiples of 16 play everywhere)")
        object.__setattr__(self, "size", (w, h))
        for name in ("background", "floor_color", "grid_color", "body_color"):
            object.__setattr__(self, name, parse_color(getattr(self, name)))
        if self.floor not in ("grid", "plain", "none"):
            raise InputError(f"floor {self.floor!r}: use 'grid', 'plain' or 'none'")
        if self.framing not in ("full", "upper"):
            raise InputError(f"framing {self.framing!r}: use 'full' or 'upper'")
        if self.supersample not in (1, 2, 3):
            raise InputError(f"supersample {self.supersample}: use 1, 2 or 3")
        if not 5.0 <= self.yfov_deg <= 90.0:
            raise InputError(f"yfov_deg {self.yfov_deg} out of 5..90")

    @property
    def width(self) -> int:
        return self.size[0]

    @property
    def height(self) -> int:
        return self.size[1]

    def with_size(self, size: tuple[int, int] | None) -> "RenderStyle":
        return self if size is None or tuple(size) == self.size else replace(self, size=tuple(size))


STYLES: dict[str, RenderStyle] = {
    "default": RenderStyle(),
    "plain": RenderStyle(floor="plain"),
    "dark": RenderStyle(background=(0.12, 0.13, 0.15), floor_color=(0.17, 0.18, 0.20),
                        grid_color=(0.27, 0.28, 0.31), body_color=(0.62, 0.60, 0.56)),
    "upper": RenderStyle(framing="upper"),
}


def parse_size(text: str) -> tuple[int, int]:
    """'512', '512x512' or '768x512' -> (width, height)."""
    parts = text.lower().replace("*", "x").split("x")
    try:
        nums = [int(p) for p in parts]
    except ValueError:
        raise InputError(f"size {text!r}: use WIDTHxHEIGHT, e.g. 512x512") from None
    if len(nums) == 1:
        nums = nums * 2
    if len(nums) != 2:
        raise InputError(f"size {text!r}: use WIDTHxHEIGHT, e.g. 512x512")
    return nums[0], nums[1]
