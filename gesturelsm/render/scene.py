"""The offscreen pyrender scene: N posed bodies, a studio floor, contact shadows, three lights, one camera.

Speed notes (Mesa llvmpipe on 2 cores; pyrender 0.1.45 is pinned, so its internals are relied on here):
* pyrender uploads a primitive's vertex buffer once; setting `primitive.positions` later does nothing. Each
  frame the body's interleaved [position | normal] buffer (pyrender's layout when a primitive has
  positions and normals only) is re-uploaded with one `glBufferSubData`: no new mesh, no new VAO.
* Shading is ours (`shaders.py`: Lambert + Blinn-Phong, ~5x cheaper than pyrender's PBR on llvmpipe), and
  so is the shader-program cache (pyrender's recompiled every program on every draw with OSMesa).
* Side by side = *tiles*: the N bodies are N meshes of one scene, each at its own place; for tile i only
  mesh i and its shadow are visible, and each tile is one pass of width x height through the same camera.
  They cost what one wide scene (bodies apart, one pass of N*width x height) costs, since llvmpipe's cost is
  shaded pixels and triangles, equal either way (docs/BENCHMARKS.md, "Why the code is built this way"). Tiles
  win on what they show: every method is seen from the identical viewpoint (in one wide perspective view
  the outer bodies are seen from the side), the framing does not depend on how far apart bodies are put,
  and shadows of neighbours cannot overlap.
* The floor is unlit (black base colour + an emissive texture, which our shader shows as stored), so it
  shows exactly the style's colours and fades into the background without a visible edge. The contact
  shadow is a small alpha texture per body (a height-weighted, blurred footprint of its vertices),
  re-uploaded each frame with `glTexSubImage2D` and drawn as a transparent quad 2 mm above the floor;
  pyrender draws transparent primitives after opaque ones, so it darkens the floor and hides behind feet.
* With OSMesa the depth buffer is not read back (pyrender's OffscreenRenderer always reads it).
* Antialiasing: OSMesa has none (EGL's pyrender path has 4x MSAA); `RenderStyle(supersample=2)` renders
  at twice the size and box-filters down (about 3x the cost) for final-quality videos.
"""
from __future__ import annotations

import sys
from typing import Sequence

import numpy as np

from .backend import PACKAGES, RenderError, select_platform
from .camera import Camera
from .shaders import program_cache
from .style import RenderStyle
from .surfaces import Surface, material

SHADOW_TEXELS = 64


def vertex_area(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(V,) a third of the area of the faces around each vertex (m^2)."""
    v = np.asarray(vertices, np.float64)
    a = 0.5 * np.linalg.norm(np.cross(v[faces[:, 1]] - v[faces[:, 0]], v[faces[:, 2]] - v[faces[:, 0]]), axis=1)
    return np.bincount(faces.reshape(-1), np.repeat(a / 3, 3), minlength=len(v))


class NormalComputer:
    """Area-weighted smooth vertex normals through one sparse (V x F) incidence matrix."""

    def __init__(self, faces: np.ndarray, num_vertices: int):
        import scipy.sparse as sp

        F = np.asarray(faces, np.int64)
        self.faces = F
        self.M = sp.csr_matrix((np.ones(F.size, np.float32), (F.reshape(-1), np.repeat(np.arange(len(F)), 3))),
                               shape=(num_vertices, len(F)))

    def __call__(self, v: np.ndarray) -> np.ndarray:
        F = self.faces
        fn = np.cross(v[F[:, 1]] - v[F[:, 0]], v[F[:, 2]] - v[F[:, 0]])      # (F, 3), |.| = 2 * area
        n = self.M @ fn
        n /= np.linalg.norm(n, axis=1, keepdims=True) + 1e-12
        return n


def _floor_texture(style: RenderStyle, size_m: float, texels: int = 1024) -> np.ndarray:
    """(texels, texels, 3) uint8 emissive texture: floor colour and grid lines fading into the background."""
    s = (np.arange(texels) + 0.5) / texels * size_m - size_m / 2             # texel centres, metres
    x, z = np.meshgrid(s, s)
    r = np.hypot(x, z)
    floor = np.asarray(style.floor_color)
    if style.floor == "grid":
        px = size_m / texels
        half = 0.011                                                          # line half-width, metres
        dx = np.abs((x + style.grid_spacing / 2) % style.grid_spacing - style.grid_spacing / 2)
        dz = np.abs((z + style.grid_spacing / 2) % style.grid_spacing - style.grid_spacing / 2)
        line = np.clip((half + px / 2 - np.minimum(dx, dz)) / px, 0.0, 1.0)   # antialiased coverage
        col = floor[None, None] + line[..., None] * (np.asarray(style.grid_color) - floor)[None, None]
    else:
        col = np.broadcast_to(floor, x.shape + (3,))
    fade = np.clip((r - 0.30 * size_m / 2) / (0.62 * size_m / 2), 0.0, 1.0)
    fade = fade * fade * (3 - 2 * fade)                                        # smoothstep to the background
    col = col + fade[..., None] * (np.asarray(style.background) - col)
    return np.round(col * 255).astype(np.uint8)


class ContactShadow:
    """A per-frame soft shadow texture from the vertices near the floor (area-weighted, blurred)."""

    def __init__(self, area: np.ndarray, floor_y: float, size_m: float, texels: int = SHADOW_TEXELS):
        self.area = np.asarray(area, np.float64)
        self.floor_y = float(floor_y)
        self.size_m = float(size_m)
        self.n = texels
        c = (np.arange(texels) + 0.5) / texels * 2 - 1
        w = np.clip(1.0 - np.hypot(*np.meshgrid(c, c)), 0.0, 1.0)              # fade out toward the edge
        self.window = np.clip(w * 3, 0, 1)

    def texture(self, vertices: np.ndarray, center_xz: np.ndarray) -> np.ndarray:
        """(n, n, 4) uint8 RGBA: row ~ z, column ~ x, black with the shadow in alpha."""
        from scipy.ndimage import gaussian_filter

        n, L = self.n, self.size_m
        h = vertices[:, 1] - self.floor_y
        keep = h < 0.8
        ij = np.floor((vertices[keep][:, [2, 0]] - (np.asarray(center_xz)[::-1] - L / 2)) / L * n).astype(np.int64)
        ok = ((ij >= 0) & (ij < n)).all(1)
        idx = ij[ok, 0] * n + ij[ok, 1]
        hh = np.maximum(h[keep][ok], 0.0)
        a = self.area[keep][ok]
        texel_area = (L / n) ** 2
        contact = np.bincount(idx, a * np.exp(-hh / 0.035), n * n).reshape(n, n) / texel_area
        soft = np.bincount(idx, a * np.exp(-hh / 0.25), n * n).reshape(n, n) / texel_area
        d = 0.9 * gaussian_filter(contact, 1.2) + 0.35 * gaussian_filter(soft, 3.5)
        alpha = 0.62 * (1.0 - np.exp(-1.6 * d)) * self.window
        out = np.zeros((n, n, 4), np.uint8)
        out[..., 3] = np.round(alpha * 255).astype(np.uint8)
        return out


class SceneRenderer:
    """Renders tiles of N bodies (same faces) through one camera. Not thread-safe; one GL context."""

    def __init__(self, faces: np.ndarray, num_vertices: int, num_bodies: int, camera: Camera,
                 style: RenderStyle, floor_y: float, rest_vertices: np.ndarray | None = None,
                 surfaces: Sequence[Surface] | None = None):
        """faces (F, 3) over all num_vertices vertices of a figure; surfaces: how its vertex ranges are drawn
        (None: one surface, the style's body colour)."""
        self.backend = select_platform()
        import pyrender
        from OpenGL import GL

        self._GL, self._pyrender = GL, pyrender
        self.style, self.camera = style, camera
        self.num_bodies = num_bodies
        self.ss = ss = int(style.supersample)
        W, H = style.width * ss, style.height * ss                    # rendered size (supersampled)
        if (camera.width, camera.height) != (W, H):
            camera = camera.resized(W, H)
        self.camera = camera
        try:
            self._r = pyrender.OffscreenRenderer(W, H)
        except Exception as exc:  # context creation: missing driver pieces, no device, ...

            raise RenderError(f"could not create an offscreen OpenGL context with {self.backend} "
                              f"({type(exc).__name__}: {exc}); try GESTURELSM_GL="
                              f"{'egl' if self.backend == 'osmesa' else 'osmesa'} or install "
                              f"{PACKAGES[self.backend]}") from None
        self._r._renderer._program_cache = program_cache()
        self._faces = np.asarray(faces, np.int64)
        self._normals = NormalComputer(self._faces, num_vertices)
        self.scene = scene = pyrender.Scene(bg_color=[*map(float, style.background), 1.0],
                                            ambient_light=[float(style.ambient)] * 3)
        cam = pyrender.PerspectiveCamera(yfov=camera.yfov, znear=camera.znear, zfar=camera.zfar,
                                         aspectRatio=camera.aspect)
        scene.add(cam, pose=camera.pose)
        self._add_lights(camera)
        target = np.asarray(camera.target)
        if style.floor != "none":
            self._add_floor(floor_y, target)
        faces = self._faces
        self._surfaces = list(surfaces) if surfaces else [Surface(0, num_vertices, faces)]
        self._uv = [sf.texcoords() for sf in self._surfaces]
        materials = [material(pyrender, GL, sf, style.body_color, style.body_roughness) for sf in self._surfaces]
        self._bodies, self._body_meshes = [], []
        for _ in range(num_bodies):
            prims = []
            for sf, mat, uv in zip(self._surfaces, materials, self._uv):
                zeros = np.zeros((sf.count, 3), np.float32)
                prims.append(pyrender.Primitive(positions=zeros, normals=zeros + np.float32([0, 0, 1]), texcoord_0=uv,
                                                indices=np.asarray(sf.faces, np.uint32), material=mat))
            mesh = pyrender.Mesh(prims)
            scene.add(mesh)
            self._bodies.append(prims)
            self._body_meshes.append(mesh)
        self._shadows: list = []
        if style.shadow and rest_vertices is not None:
            height = float(np.ptp(rest_vertices[:, 1]))
            self._shadow = ContactShadow(vertex_area(rest_vertices, self._faces), floor_y, 1.1 * max(height, 0.5))
            for _ in range(num_bodies):
                self._shadows.append(self._add_shadow_quad(floor_y))

    # ---- construction -------------------------------------------------------------------------------
    def _add_lights(self, camera: Camera) -> None:
        pr, s = self._pyrender, self.style

        def toward(direction: np.ndarray) -> np.ndarray:   # pose whose -z axis points along `direction`
            back = -direction / np.linalg.norm(direction)
            right = np.cross([0.0, 1.0, 0.0], back)
            right /= np.linalg.norm(right)
            M = np.eye(4)
            M[:3, 0], M[:3, 1], M[:3, 2] = right, np.cross(back, right), back
            return M

        view_dir = np.asarray(camera.target) - np.asarray(camera.eye)
        view_dir[1] = 0.0
        view_dir /= np.linalg.norm(view_dir)
        right = np.cross(view_dir, [0.0, 1.0, 0.0])
        key = view_dir * 1.0 + right * 1.15 + np.array([0.0, -1.3, 0.0])       # from upper left, front
        fill = view_dir * 1.0 - right * 0.9 + np.array([0.0, -0.25, 0.0])      # from the right, lower
        rim = -view_dir * 1.0 - right * 0.3 + np.array([0.0, -0.9, 0.0])       # from behind, above
        self.scene.add(pr.DirectionalLight(color=[1.0, 0.97, 0.92], intensity=float(s.key_light)), pose=toward(key))
        self.scene.add(pr.DirectionalLight(color=[0.90, 0.94, 1.0], intensity=float(s.fill_light)), pose=toward(fill))
        if s.rim_light > 0:
            self.scene.add(pr.DirectionalLight(color=[1.0, 1.0, 1.0], intensity=float(s.rim_light)), pose=toward(rim))

    def _add_floor(self, floor_y: float, target: np.ndarray) -> None:
        pr, GL = self._pyrender, self._GL
        size = 12.0
        tex = pr.Texture(source=_floor_texture(self.style, size), source_channels="RGB",
                         sampler=pr.Sampler(magFilter=GL.GL_LINEAR, minFilter=GL.GL_LINEAR_MIPMAP_LINEAR,
                                            wrapS=GL.GL_CLAMP_TO_EDGE, wrapT=GL.GL_CLAMP_TO_EDGE))
        mat = pr.MetallicRoughnessMaterial(baseColorFactor=[0.0, 0.0, 0.0, 1.0], metallicFactor=0.0,
                                           roughnessFactor=1.0, emissiveTexture=tex, emissiveFactor=[1.0, 1.0, 1.0])
        h = size / 2
        # texture row 0 is the image top = v 1 (pyrender flips on upload): v = 1 at z = -h
        pos = np.array([[-h, 0, -h], [h, 0, -h], [h, 0, h], [-h, 0, h]], np.float32)
        uv = np.array([[0, 1], [1, 1], [1, 0], [0, 0]], np.float32)
        prim = pr.Primitive(positions=pos, texcoord_0=uv, material=mat,   # no normals: unlit, cheapest path
                            indices=np.array([[0, 2, 1], [0, 3, 2]], np.uint32))
        pose = np.eye(4)
        pose[:3, 3] = [target[0], floor_y, target[2]]
        self.scene.add(pr.Mesh([prim]), pose=pose)

    def _add_shadow_quad(self, floor_y: float):
        pr, GL = self._pyrender, self._GL
        n = self._shadow.n
        tex = pr.Texture(source=np.zeros((n, n, 4), np.uint8), source_channels="RGBA",
                         sampler=pr.Sampler(magFilter=GL.GL_LINEAR, minFilter=GL.GL_LINEAR,
                                            wrapS=GL.GL_CLAMP_TO_EDGE, wrapT=GL.GL_CLAMP_TO_EDGE))
        # alpha < 1: pyrender 0.1.45 never marks a texture transparent, the factor makes the material so
        mat = pr.MetallicRoughnessMaterial(baseColorFactor=[0.0, 0.0, 0.0, 0.999], baseColorTexture=tex,
                                           metallicFactor=0.0, roughnessFactor=1.0, alphaMode="BLEND")
        h = self._shadow.size_m / 2
        pos = np.array([[-h, 0, -h], [h, 0, -h], [h, 0, h], [-h, 0, h]], np.float32)
        # our texture rows are uploaded unflipped: row i <-> t = (i + .5) / n <-> z
        uv = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], np.float32)
        prim = pr.Primitive(positions=pos, normals=np.tile([0, 1, 0], (4, 1)).astype(np.float32), texcoord_0=uv,
                            indices=np.array([[0, 2, 1], [0, 3, 2]], np.uint32), material=mat)
        mesh = pr.Mesh([prim])
        node = self.scene.add(mesh, pose=np.eye(4))
        return node, mesh, tex, floor_y + 0.002

    # ---- per frame ----------------------------------------------------------------------------------
    def _upload_body(self, i: int, v: np.ndarray, normals: np.ndarray | None = None) -> None:
        v = np.asarray(v, np.float32)
        n = (self._normals(v) if normals is None else np.asarray(normals)).astype(np.float32)
        GL = self._GL
        for prim, sf, uv in zip(self._bodies[i], self._surfaces, self._uv):
            pv, pn = v[sf.start:sf.stop], n[sf.start:sf.stop]
            if prim._vaid is None:                           # not yet in the context: first upload by pyrender
                prim.positions, prim.normals = pv, pn
                continue
            data = np.ascontiguousarray(np.concatenate([pv, pn] + ([] if uv is None else [uv]), 1))
            GL.glBindBuffer(GL.GL_ARRAY_BUFFER, prim._buffers[0])
            GL.glBufferSubData(GL.GL_ARRAY_BUFFER, 0, data.nbytes, data)
            GL.glBindBuffer(GL.GL_ARRAY_BUFFER, 0)

    def _upload_shadow(self, i: int, v: np.ndarray, center_xz: np.ndarray) -> None:
        node, _, tex, y = self._shadows[i]
        pose = np.eye(4)
        pose[:3, 3] = [center_xz[0], y, center_xz[1]]
        self.scene.set_pose(node, pose)
        img = self._shadow.texture(v, center_xz)
        if tex._texid is None:                               # first upload by pyrender, which flips rows
            tex.source = img[::-1]
            return
        GL = self._GL
        GL.glBindTexture(GL.GL_TEXTURE_2D, tex._texid)
        GL.glTexSubImage2D(GL.GL_TEXTURE_2D, 0, 0, 0, img.shape[1], img.shape[0], GL.GL_RGBA,
                           GL.GL_UNSIGNED_BYTE, np.ascontiguousarray(img))
        GL.glBindTexture(GL.GL_TEXTURE_2D, 0)

    def render(self, vertices: Sequence[np.ndarray], centers_xz: Sequence[np.ndarray] | None = None,
               normals: Sequence[np.ndarray] | None = None) -> list[np.ndarray]:
        """vertices: one (V, 3) array per body; centers_xz: where each body's shadow is centred (pelvis x, z);
        normals: one (V, 3) array per body (None: smooth normals from the triangles).
        Returns one (H, W, 3) uint8 image per body."""
        if len(vertices) != self.num_bodies:
            raise ValueError(f"expected {self.num_bodies} bodies, got {len(vertices)}")
        self._r._platform.make_current()
        for i, v in enumerate(vertices):
            self._upload_body(i, v, None if normals is None else normals[i])
            if self._shadows:
                c = np.asarray(centers_xz[i]) if centers_xz is not None else np.asarray(v)[:, [0, 2]].mean(0)
                self._upload_shadow(i, np.asarray(v), c)
        tiles = []
        for i in range(self.num_bodies):
            for k, mesh in enumerate(self._body_meshes):
                mesh.is_visible = k == i
            for k, (_, mesh, _, _) in enumerate(self._shadows):
                mesh.is_visible = k == i
            tiles.append(self._render_pass())
        return tiles

    def _render_pass(self) -> np.ndarray:
        r = self._r
        if r._platform.supports_framebuffers():
            color, _ = r.render(self.scene)
            img = color[..., :3]
        else:
            r._platform.make_current()
            r._renderer.viewport_width, r._renderer.viewport_height = r.viewport_width, r.viewport_height
            r._renderer.render(self.scene, self._pyrender.RenderFlags.NONE)
            img = r._renderer.read_color_buf()[..., :3]
        if self.ss > 1:                                               # box-filter down to the tile size
            k = self.ss
            h, w = img.shape[0] // k, img.shape[1] // k
            img = img.reshape(h, k, w, k, 3).mean((1, 3)).round().astype(np.uint8)
        return np.ascontiguousarray(img)

    def close(self) -> None:
        r, self._r = getattr(self, "_r", None), None
        if r is not None and not sys.is_finalizing():
            r.delete()

    def __enter__(self) -> "SceneRenderer":
        return self

    def __exit__(self, *exc) -> None:
        self.close()
