"""GLSL 330 sources of the rasteriser; variants are selected by #defines (normal and/or colour outputs).

Attachment 0 is always RG32F = (camera z in mm, instance id as float); colour (RGBA8) and normal (RGBA32F)
follow in that order when requested.  The camera z is a perspective-correct varying (z is affine on each
triangle in 3D, so the interpolation is exact up to float32 rounding) -- the non-linear z-buffer is only
used for the depth test.
"""
from __future__ import annotations

VERTEX = """
#version 330
uniform mat4 u_mv;      // model (mm, scaled) -> camera (mm)
uniform mat4 u_proj;    // camera -> clip (see projection.py)
in vec3 in_pos;
out float v_z;
#ifdef WITH_NORMAL
uniform mat3 u_rot;     // model -> camera rotation (for normals)
in vec3 in_nrm;
out vec3 v_n;
#endif
#ifdef WITH_COLOR
in vec2 in_uv;
in vec3 in_col;
out vec2 v_uv;
out vec3 v_col;
out vec3 v_p;
#endif
void main() {
    vec4 pc = u_mv * vec4(in_pos, 1.0);
    v_z = pc.z;
#ifdef WITH_NORMAL
    v_n = u_rot * in_nrm;
#endif
#ifdef WITH_COLOR
    v_uv = in_uv;
    v_col = in_col;
    v_p = pc.xyz;
#endif
    gl_Position = u_proj * pc;
}
"""

FRAGMENT = """
#version 330
uniform float u_inst;
in float v_z;
layout(location = 0) out vec2 o_geom;
#ifdef WITH_NORMAL
in vec3 v_n;
layout(location = LOC_NORMAL) out vec4 o_normal;
#endif
#ifdef WITH_COLOR
uniform sampler2D u_tex;
uniform float u_shade;
in vec2 v_uv;
in vec3 v_col;
in vec3 v_p;
layout(location = LOC_COLOR) out vec4 o_color;
#endif
void main() {
    o_geom = vec2(v_z, u_inst);
#ifdef WITH_NORMAL
    vec3 n = v_n / max(length(v_n), 1e-12);
    if (!gl_FrontFacing) n = -n;   // inside of open meshes: normal towards the viewer
    o_normal = vec4(n, 0.0);
#endif
#ifdef WITH_COLOR
#ifdef SRGB_TEXTURES
    // an sRGB texture: GL decodes each texel to linear light before filtering and mip averaging; the
    // filtered colour is encoded back to sRGB here, so the output is in the same encoding as otherwise
    vec3 t = texture(u_tex, v_uv).rgb;
    vec3 c = mix(12.92 * t, 1.055 * pow(t, vec3(1.0 / 2.4)) - 0.055, step(vec3(0.0031308), t)) * v_col;
#else
    vec3 c = texture(u_tex, v_uv).rgb * v_col;
#endif
    if (u_shade > 0.0) {
#ifndef WITH_NORMAL
        vec3 n = normalize(cross(dFdx(v_p), dFdy(v_p)));
#endif
        float l = abs(dot(n, normalize(v_p)));
        c *= (1.0 - u_shade) + u_shade * l;
    }
    o_color = vec4(c, 1.0);
#endif
}
"""


def sources(with_color: bool, with_normal: bool, srgb_textures: bool = False) -> tuple[str, str]:
    """(vertex, fragment) GLSL sources for the requested output variant (``srgb_textures``: the
    textures are sRGB textures, filtered in linear light; see ``Renderer``)."""
    defs = ["#define SRGB_TEXTURES"] if srgb_textures else []
    loc = 1
    if with_color:
        defs += ["#define WITH_COLOR", f"#define LOC_COLOR {loc}"]
        loc += 1
    if with_normal:
        defs += ["#define WITH_NORMAL", f"#define LOC_NORMAL {loc}"]
        loc += 1
    head = "\n".join(defs) + "\n"

    def inject(src: str) -> str:
        lines = src.strip().split("\n")
        return lines[0] + "\n" + head + "\n".join(lines[1:]) + "\n"

    return inject(VERTEX), inject(FRAGMENT)
