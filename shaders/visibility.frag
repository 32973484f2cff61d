#version 410
// Nearest distance per texel, kept by MIN blending (no depth buffer needed, full float precision).
in vec3 g_local;
flat in float g_surface;
uniform int u_orthographic;
layout(location = 0) out vec2 out_distance;

#include "visibility_store.glsl"

void main() {
    out_distance = stored_distance(u_orthographic != 0 ? g_local.z : length(g_local), g_surface);
}
