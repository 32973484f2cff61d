#version 410
// Raises the subdivision level of a triangle's texels (MAX blending into the level map):
// all of them (regular refinement) or, for adaptive subdivision, those on the current shot's
// shadow boundary: partly visible, or visible unlike a lightmap neighbour on the same surface.
flat in vec2 g_texel[3];
uniform float u_level;
uniform int u_boundary_only;
uniform sampler2D u_position;
uniform sampler2D u_normal;
layout(location = 0) out vec4 out_level;

#include "projection.glsl"
#include "visibility_test.glsl"
#include "texel_clip.glsl"

float visibility_of(ivec2 texel) {
    return visible_from_eye(texelFetch(u_position, texel, 0).xyz,
                            decode_normal(texelFetch(u_normal, texel, 0).xy),
                            decode_surface(texelFetch(u_material, texel, 0).a), 0);
}

void main() {
    vec2 covered_centre;
    if (clip_triangle_to_texel(floor(gl_FragCoord.xy), covered_centre) <= 1e-7) discard;
    if (u_boundary_only != 0) {
        ivec2 texel = ivec2(gl_FragCoord.xy);
        ivec2 size = textureSize(u_position, 0);
        vec3 normal = decode_normal(texelFetch(u_normal, texel, 0).xy);
        float own = visibility_of(texel);
        bool boundary = own > 0.0 && own < 1.0;
        const ivec2 NEIGHBOURS[4] = ivec2[4](ivec2(1, 0), ivec2(-1, 0), ivec2(0, 1), ivec2(0, -1));
        for (int i = 0; i < 4 && !boundary; ++i) {
            ivec2 n = texel + NEIGHBOURS[i];
            if (any(lessThan(n, ivec2(0))) || any(greaterThanEqual(n, size))) continue;
            if (texelFetch(u_position, n, 0).w <= 0.0) continue;
            if (dot(decode_normal(texelFetch(u_normal, n, 0).xy), normal) < 0.9) continue;
            boundary = abs(visibility_of(n) - own) >= 0.5;
        }
        if (!boundary) discard;
    }
    out_level = vec4(encode_level(u_level));
}
