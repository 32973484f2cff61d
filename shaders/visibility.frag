#version 410
// Nearest distance per texel, kept by MIN blending (no depth buffer needed, full float precision).
in vec3 g_local;
uniform int u_orthographic;
layout(location = 0) out float out_distance;
void main() {
    out_distance = u_orthographic != 0 ? g_local.z : length(g_local);
}
