"""Our replacement for pyrender's `mesh.vert` / `mesh.frag`: Lambert + Blinn-Phong instead of PBR.

Why: on Mesa's llvmpipe, pyrender's PBR fragment shader (GGX specular, Fresnel, shadow-map branches per
light) is most of the cost of a body frame (docs/BENCHMARKS.md, "Why the code is built this way"). This shader keeps
what the look needs: diffuse from each directional light (base / pi * radiance, as pyrender's PBR diffuse, so light
intensities mean the same), a soft Blinn-Phong highlight that fades with roughness, ambient, and two texture uses:
* `emissiveTexture` is added *after* gamma encoding, i.e. shown exactly as stored (sRGB): the unlit floor;
* `baseColorTexture` alpha (times the factor's alpha) is the output alpha: the contact-shadow decal; with a
  factor alpha of 1 a texel of alpha < 0.5 is discarded instead (a character's cut-out, glTF's MASK).
The vertex shader takes normals through mat3(M) (rigid node transforms only) instead of pyrender's
per-vertex 4x4 inverse-transpose.

pyrender loads shaders from a folder by file name, so the sources are written once per process to a
temporary folder (this keeps them inside the Python package, whatever way it was installed).
pyrender textually replaces define names (NORMAL_LOC, MAX_DIRECTIONAL_LIGHTS, ...) and turns `#ifdef X`
into `#if 0/1`.
"""
from __future__ import annotations

import atexit
import shutil
import tempfile
from functools import lru_cache
from pathlib import Path

MESH_VERT = """#version 330 core
layout(location = 0) in vec3 position;
#ifdef NORMAL_LOC
layout(location = NORMAL_LOC) in vec3 normal;
#endif
#ifdef TEXCOORD_0_LOC
layout(location = TEXCOORD_0_LOC) in vec2 texcoord_0;
#endif
layout(location = INST_M_LOC) in mat4 inst_m;

uniform mat4 M;
uniform mat4 V;
uniform mat4 P;

out vec3 frag_position;
#ifdef NORMAL_LOC
out vec3 frag_normal;
#endif
#ifdef TEXCOORD_0_LOC
out vec2 uv_0;
#endif

void main()
{
    mat4 model = M * inst_m;
    vec4 world = model * vec4(position, 1.0);
    gl_Position = P * V * world;
    frag_position = world.xyz;
#ifdef NORMAL_LOC
    frag_normal = mat3(model) * normal;
#endif
#ifdef TEXCOORD_0_LOC
    uv_0 = texcoord_0;
#endif
}
"""

MESH_FRAG = """#version 330 core
struct DirectionalLight {
    vec3 color;
    float intensity;
    vec3 direction;
};
struct Material {
    vec3 emissive_factor;
    vec4 base_color_factor;
    float metallic_factor;
    float roughness_factor;
#ifdef HAS_EMISSIVE_TEX
    sampler2D emissive_texture;
#endif
#ifdef HAS_BASE_COLOR_TEX
    sampler2D base_color_texture;
#endif
};

uniform Material material;
uniform DirectionalLight directional_lights[MAX_DIRECTIONAL_LIGHTS];
uniform int n_directional_lights;
uniform vec3 cam_pos;
uniform vec3 ambient_light;

in vec3 frag_position;
#ifdef NORMAL_LOC
in vec3 frag_normal;
#endif
#ifdef TEXCOORD_0_LOC
in vec2 uv_0;
#endif

out vec4 frag_color;

void main()
{
    vec4 base = material.base_color_factor;                       // linear
#ifdef HAS_BASE_COLOR_TEX
    vec4 tex = texture(material.base_color_texture, uv_0);
    base = base * vec4(pow(tex.rgb, vec3(2.2)), tex.a);
    if (material.base_color_factor.a > 0.9995 && base.a < 0.5) discard;   // a cut-out (MASK) texel
#endif
    vec3 color = base.rgb * ambient_light;
#ifdef NORMAL_LOC
    vec3 n = normalize(frag_normal);
    vec3 v = normalize(cam_pos - frag_position);
    float rough = clamp(material.roughness_factor, 0.05, 1.0);
    float shininess = 2.0 / (rough * rough * rough * rough) + 2.0;
    float ks = 0.18 * (1.0 - rough) * (shininess + 8.0) / 25.13;  // normalised Blinn-Phong
    for (int i = 0; i < n_directional_lights; i++) {
        vec3 l = -normalize(directional_lights[i].direction);
        vec3 radiance = directional_lights[i].intensity * directional_lights[i].color;
        float nl = max(dot(n, l), 0.0);
        vec3 h = normalize(l + v);
        float spec = ks * pow(max(dot(n, h), 0.0), shininess);
        color += radiance * nl * (base.rgb * 0.3183 + vec3(spec));
    }
#endif
    vec3 srgb = pow(max(color, vec3(0.0)), vec3(1.0 / 2.2));
#ifdef HAS_EMISSIVE_TEX
    srgb += texture(material.emissive_texture, uv_0).rgb * material.emissive_factor;
#endif
    frag_color = vec4(clamp(srgb, 0.0, 1.0), base.a);
}
"""


@lru_cache(maxsize=1)
def shader_dir() -> str:
    d = Path(tempfile.mkdtemp(prefix="gesturelsm-shaders-"))
    (d / "mesh.vert").write_text(MESH_VERT)
    (d / "mesh.frag").write_text(MESH_FRAG)
    atexit.register(shutil.rmtree, d, True)
    return str(d)


def program_cache():
    """A pyrender ShaderProgramCache over our shaders, keyed on shaders + defines only.

    pyrender's own key includes `OpenGL.contextdata.getContext()`, which with PyOpenGL 3.1.10's OSMesa is a
    new pointer object on every call: with that key every draw would recompile its program and the cache would
    grow without bound. One renderer has one context, so the context is left out of the key.
    """
    from pyrender.shader_program import ShaderProgramCache

    class StableProgramCache(ShaderProgramCache):
        def __init__(self) -> None:
            super().__init__(shader_dir=shader_dir())
            self._stable: dict = {}

        def get_program(self, vertex_shader, fragment_shader, geometry_shader=None, defines=None):
            key = (vertex_shader, fragment_shader, geometry_shader, tuple(sorted((defines or {}).items())))
            program = self._stable.get(key)
            if program is None:
                program = super().get_program(vertex_shader, fragment_shader, geometry_shader, defines)
                self._stable[key] = program
            return program

        def clear(self) -> None:
            super().clear()
            self._stable = {}

    return StableProgramCache()
