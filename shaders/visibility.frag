#version 410
// Nearest distance per texel, kept by MIN blending (no depth buffer needed, full float precision).
in vec3 g_local;
flat in float g_surface;
flat in int g_faces_away;
uniform int u_orthographic;
layout(location = 0) out vec2 out_distance;

#include "visibility_store.glsl"

void main() {
    out_distance = stored_distance(u_orthographic != 0 ? g_local.z : length(g_local), g_surface,
                                   g_faces_away != 0);
}
