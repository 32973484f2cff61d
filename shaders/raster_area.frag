#version 410
// Exact world area of every texel: the clipped area of each triangle in the texel, summed
// over triangles by additive blending into the alpha channel of the position map.
flat in vec2 g_texel[3];
flat in float g_area_per_texel;

layout(location = 0) out vec4 out_area;

#include "texel_clip.glsl"

void main() {
    vec2 covered_centre;
    float covered = clip_triangle_to_texel(floor(gl_FragCoord.xy), covered_centre);
    if (covered <= 0.0) discard;
    out_area = vec4(0.0, 0.0, 0.0, covered * g_area_per_texel);
}
