#version 410
// Routes each triangle, projected by the vertex shader, to the hemisphere layers drawn
// (u_face_count: 1 for a one-sided shooter, 2 for a two-sided one or a point light), clipped to
// the hemisphere.
layout(triangles) in;  // one invocation draws every layer (see visibility.geom)
layout(triangle_strip, max_vertices = 6) out;

uniform int u_face_count;

in vec4 v_front[];
in vec4 v_back[];
in float v_height_front[];
in float v_height_back[];
in float v_distance[];
in vec3 v_local[];
in float v_surface[];

#include "projection.glsl"
flat out vec4 g_plane;  // the triangle's plane in the hemisphere's frame: normal, offset
flat out float g_surface;
flat out int g_faces_away;

#include "visibility_store.glsl"

// The triangle on hemisphere 'side'.
void draw(int side) {
    // A triangle whose plane passes through the eye covers no solid angle, but its corners
    // would span a chord of the disc.
    vec3 n = cross(v_local[1] - v_local[0], v_local[2] - v_local[0]);
    float size = max(v_distance[0], max(v_distance[1], v_distance[2]));
    if (abs(dot(n, v_local[0])) <= 1e-6 * length(n) * size) return;
    vec3 h0 = hemisphere_local(v_local[0], side);
    bool away = faces_away_from_eye(v_local[0], v_local[1], v_local[2]);
    vec3 plane_normal = hemisphere_local(n, side);
    for (int i = 0; i < 3; ++i) {
        g_plane = vec4(plane_normal, dot(plane_normal, h0));
        g_surface = v_surface[0];
        g_faces_away = int(away);
        gl_Position = side == 0 ? v_front[i] : v_back[i];
        gl_ClipDistance[0] = side == 0 ? v_height_front[i] : v_height_back[i];
        gl_Layer = side;
        EmitVertex();
    }
    EndPrimitive();
}

void main() {
    for (int side = 0; side < u_face_count; ++side) draw(side);
}
