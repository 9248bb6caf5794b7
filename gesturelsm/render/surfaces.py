"""`Surface`: one drawn part of a figure (a range of its vertices, their triangles and their look), and the
pyrender material for it.

The mannequin is one surface in the style's body colour. A character is one surface per glTF primitive: its
base colour factor (linear) and, when it has one, its base colour texture (sRGB) through TEXCOORD_0.
Alpha as glTF says: OPAQUE ignores the texture's alpha; MASK cuts out texels below the cutoff (the texture's
alpha is thresholded to 0 / 255 here and the shader discards alpha < 0.5 when the factor's alpha is 1);
BLEND blends (factor alpha kept below 1, so nothing is cut out).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

REPEAT, CLAMP, MIRROR = 10497, 33071, 33648


@dataclass
class Surface:
    start: int                                   # first vertex of the figure's vertex array it uses
    count: int                                   # how many
    faces: np.ndarray                            # (F, 3) indices into its own range (0 .. count-1)
    color: tuple[float, float, float, float] | None = None   # linear RGBA; None: the style's body colour
    texture: np.ndarray | None = None            # (H, W, 4) uint8 sRGB
    uv: np.ndarray | None = None                 # (count, 2) glTF convention (v down the image)
    wrap: tuple[int, int] = (REPEAT, REPEAT)
    alpha_mode: str = "OPAQUE"
    alpha_cutoff: float = 0.5
    double_sided: bool = False
    roughness: float | None = None               # None: the style's body roughness

    @property
    def stop(self) -> int:
        return self.start + self.count

    def texcoords(self) -> np.ndarray | None:
        """(count, 2) float32 in pyrender's convention (it flips the image on upload: v up), or None."""
        if self.texture is None or self.uv is None:
            return None
        uv = np.asarray(self.uv, np.float32).copy()
        uv[:, 1] = 1.0 - uv[:, 1]
        return uv


def material(pyrender, GL, surface: Surface, body_color, roughness: float):
    """The pyrender material that draws `surface` with our shaders (shaders.py)."""
    if surface.color is None:
        rgba = [*(np.asarray(body_color, np.float64) ** 2.2), 1.0]                  # factor is linear
    else:
        rgba = [float(c) for c in surface.color]
    mode = surface.alpha_mode if surface.alpha_mode in ("OPAQUE", "MASK", "BLEND") else "OPAQUE"
    tex = None
    if surface.texture is not None and surface.uv is not None:
        img = np.asarray(surface.texture, np.uint8)
        if mode == "OPAQUE":
            img = img[..., :3]
        elif mode == "MASK":
            keep = img[..., 3].astype(np.float64) * rgba[3] >= 255.0 * surface.alpha_cutoff
            img = img.copy()
            img[..., 3] = np.where(keep, 255, 0)
        wrap = {REPEAT: GL.GL_REPEAT, CLAMP: GL.GL_CLAMP_TO_EDGE, MIRROR: GL.GL_MIRRORED_REPEAT}
        tex = pyrender.Texture(source=img, source_channels="RGBA" if img.shape[-1] == 4 else "RGB",
                               sampler=pyrender.Sampler(magFilter=GL.GL_LINEAR, minFilter=GL.GL_LINEAR_MIPMAP_LINEAR,
                                                        wrapS=wrap.get(surface.wrap[0], GL.GL_REPEAT),
                                                        wrapT=wrap.get(surface.wrap[1], GL.GL_REPEAT)))
    if mode != "BLEND":
        rgba[3] = 1.0                                # opaque and cut-out surfaces: the shader's discard rule
    else:
        rgba[3] = min(rgba[3], 0.999)
    return pyrender.MetallicRoughnessMaterial(
        baseColorFactor=rgba, baseColorTexture=tex, metallicFactor=0.0,
        roughnessFactor=float(roughness if surface.roughness is None else surface.roughness),
        alphaMode="BLEND" if mode == "BLEND" else "OPAQUE", doubleSided=bool(surface.double_sided))
