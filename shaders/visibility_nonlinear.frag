#version 410
// Non-linear hemisphere projection, second step: a texel is kept only if its direction lies
// inside the triangle's spherical image (on the inner side of the three planes through the eye
// and each edge), and it stores the true distance along that direction to the triangle.
flat in vec3 g_corner[3];
flat in float g_surface;
flat in int g_faces_away;
uniform float u_resolution;
layout(location = 0) out vec2 out_distance;

#include "projection.glsl"
#include "visibility_store.glsl"

void main() {
    vec2 p = gl_FragCoord.xy / u_resolution * 2.0 - 1.0;
    if (dot(p, p) > 1.0) discard;  // below the horizon
    vec3 d = inverse_stereographic(p);
    vec3 e0 = cross(g_corner[0], g_corner[1]);
    vec3 e1 = cross(g_corner[1], g_corner[2]);
    vec3 e2 = cross(g_corner[2], g_corner[0]);
    float inside = sign(dot(e0, g_corner[2]));
    if (dot(e0, d) * inside < 0.0 || dot(e1, d) * inside < 0.0 || dot(e2, d) * inside < 0.0)
        discard;
    vec3 n = cross(g_corner[1] - g_corner[0], g_corner[2] - g_corner[0]);
    float distance = dot(n, g_corner[0]) / dot(n, d);
    if (!(distance > 0.0)) discard;
    out_distance = stored_distance(distance, g_surface, g_faces_away != 0);
}
