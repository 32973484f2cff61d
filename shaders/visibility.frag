#version 410
// Nearest distance per texel, kept by MIN blending (no depth buffer needed, full float precision).
// Every face's frame (projection.glsl) is right-handed and looks along +z, so a triangle whose
// corners wind counter-clockwise on the face (OpenGL's front, the default) turns its back to the
// eye: dot(cross(c1 - c0, c2 - c0), c0) > 0, faces_away_from_eye. On the sun's orthographic
// face the same holds for its parallel rays.
in vec3 g_local;
flat in float g_surface;
uniform int u_orthographic;
layout(location = 0) out vec2 out_distance;

#include "visibility_store.glsl"

void main() {
    out_distance = stored_distance(u_orthographic != 0 ? g_local.z : length(g_local), g_surface,
                                   gl_FrontFacing);
}
