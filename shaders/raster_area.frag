#version 410
// Exact world area of every texel: the clipped area of each triangle in the texel, summed
// over triangles by additive blending into the alpha channel of the position map. Beside it,
// for the texels whose surface bends within them (preprocess.measure_surface), the sum of the
// shading normals weighted by the share of the texel each triangle covers, and the sum of
// those shares.
flat in vec2 g_texel[3];
flat in vec3 g_normal[3];
flat in vec3 g_face_normal;
flat in float g_area_per_texel;

layout(location = 0) out vec4 out_area;
layout(location = 1) out vec4 out_normal_sum;

#include "texel_clip.glsl"
#include "shading_normal.glsl"

void main() {
    vec2 covered_centre;
    float covered = clip_triangle_to_texel(floor(gl_FragCoord.xy), covered_centre);
    if (covered <= 0.0) discard;
    out_area = vec4(0.0, 0.0, 0.0, covered * g_area_per_texel);
    // The normal at the covered part's centre stands for the part (the interpolated normal
    // varies linearly over it).
    out_normal_sum = covered * vec4(shading_normal(covered_barycentric(covered_centre)), 1.0);
}
