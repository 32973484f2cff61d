#version 410
// Where the drawn (straight-edged) triangle covers a texel: the distance along the texel's
// direction to the triangle's plane, kept by MIN blending. The shape stays the per-vertex
// projection's; the depth is exact (interpolating the corners' distances, as the paper does,
// shadows receivers on their own surface), and a direction that does not meet the plane in
// front of the eye is left open.
flat in vec4 g_plane;
flat in float g_surface;
flat in int g_faces_away;
uniform float u_resolution;
layout(location = 0) out vec2 out_distance;

#include "projection.glsl"
#include "visibility_store.glsl"

void main() {
    vec3 direction = inverse_stereographic(gl_FragCoord.xy / u_resolution * 2.0 - 1.0);
    float distance = g_plane.w / dot(g_plane.xyz, direction);
    if (!(distance > 0.0)) discard;
    out_distance = stored_distance(distance, g_surface, g_faces_away != 0);
}
