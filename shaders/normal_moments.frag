#version 410
// Second moments of the shading normals over each texel in the tangent plane of its sample's
// normal (tangent_of() and the bitangent), weighted by the share of the texel each triangle
// covers and summed by additive blending (preprocess.measure_surface).
flat in vec2 g_texel[3];
flat in vec3 g_normal[3];
flat in vec3 g_face_normal;

uniform sampler2D u_normal;   // the sample's normal

layout(location = 0) out vec4 out_moments;   // tt, bb, tb

#include "texel_maps.glsl"
#include "texel_clip.glsl"
#include "shading_normal.glsl"

void main() {
    vec2 covered_centre;
    float covered = clip_triangle_to_texel(floor(gl_FragCoord.xy), covered_centre);
    if (covered <= 0.0) discard;
    vec3 sample_normal = decode_normal(texelFetch(u_normal, ivec2(gl_FragCoord.xy), 0).xy);
    vec3 t = tangent_of(sample_normal);
    vec3 n = shading_normal(covered_barycentric(covered_centre));
    vec2 along = vec2(dot(n, t), dot(n, cross(sample_normal, t)));
    out_moments = covered * vec4(along * along, along.x * along.y, 0.0);
}
