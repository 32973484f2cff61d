#version 410
// Adaptive subdivision (the paper's Section 2): drawn over one receiving triangle in lightmap
// space inside an occlusion query, a fragment passes for each of its texels facing the
// shooter that is lit (u_count_hidden 0) or in shadow (1), so two queries give the
// triangle's shadowed share.
flat in vec2 g_texel[3];
uniform sampler2D u_position;
uniform sampler2D u_normal;
uniform int u_count_hidden;
uniform int u_clip_below;   // a one-sided shooter lights only what lies in front of it
layout(location = 0) out vec4 out_unused;

#include "projection.glsl"
#include "visibility_test.glsl"
#include "texel_clip.glsl"

void main() {
    vec2 covered_centre;
    if (clip_triangle_to_texel(floor(gl_FragCoord.xy), covered_centre) <= 1e-7) discard;
    ivec2 texel = ivec2(gl_FragCoord.xy);
    vec4 position = texelFetch(u_position, texel, 0);
    if (position.w <= 0.0) discard;
    vec3 normal = decode_normal(texelFetch(u_normal, texel, 0).xy);
    vec3 to_eye = u_orthographic != 0 ? -u_frame[2] : u_eye - position.xyz;
    if (dot(normal, to_eye) <= 0.0) discard;
    if (u_clip_below != 0 && dot(position.xyz - u_eye, u_frame[2]) <= 0.0) discard;
    bool hidden = visible_from_eye(position.xyz, normal,
                                   decode_surface(texelFetch(u_material, texel, 0).a), 0) < 0.5;
    if (hidden != (u_count_hidden != 0)) discard;
    out_unused = vec4(0.0);
}
