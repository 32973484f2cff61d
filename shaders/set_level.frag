#version 410
// Raises the subdivision level of the texels a triangle covers (MAX blending into the
// tangent map's w).
flat in vec2 g_texel[3];
uniform float u_level;
layout(location = 0) out vec4 out_level;

#include "texel_clip.glsl"

void main() {
    vec2 covered_centre;
    if (clip_triangle_to_texel(floor(gl_FragCoord.xy), covered_centre) <= 1e-7) discard;
    out_level = vec4(0.0, 0.0, 0.0, u_level);
}
