#version 410
// The stereographic projection with the casters tessellated on the fly (the paper's proposed
// remedy for its Figure 5): a caster at subdivision level k becomes n x n sub-triangles, n
// growing with the angle its longest edge spans, up to 2^k, so its straight edges in the map
// follow the true arcs closely. Each sub-vertex is projected as the vertex shader projects
// the corners.
layout(triangles, invocations = 2) in;
layout(triangle_strip, max_vertices = 80) out;   // rows of strips: n^2 + 2n for n = 8

uniform int u_face_count;

in vec3 v_local[];
in float v_distance[];
in float v_caster_level[];
in float v_surface[];
flat out vec4 g_plane;  // the triangle's plane in the hemisphere's frame: normal, offset
flat out float g_surface;
flat out int g_faces_away;

#include "projection.glsl"
#include "visibility_store.glsl"

const float MAX_SUB_EDGE_ANGLE = 0.1309;  // 7.5 degrees

bool g_away;   // of the triangle being emitted

void emit(vec3 local, int side, vec4 plane) {
    vec3 h = hemisphere_local(local, side);
    g_plane = plane;
    g_surface = v_surface[0];
    g_faces_away = int(g_away);
    gl_Position = vec4(stereographic(h), 0.0, 1.0);
    gl_ClipDistance[0] = h.z;
    gl_Layer = side;
    EmitVertex();
}

float edge_angle(vec3 a, vec3 b) {
    return acos(clamp(dot(normalize(a), normalize(b)), -1.0, 1.0));
}

void main() {
    int side = gl_InvocationID;
    if (side >= u_face_count) return;
    vec3 c0 = v_local[0], c1 = v_local[1], c2 = v_local[2];
    g_away = faces_away_from_eye(c0, c1, c2);
    vec3 n = cross(c1 - c0, c2 - c0);
    float size = max(v_distance[0], max(v_distance[1], v_distance[2]));
    if (abs(dot(n, c0)) <= 1e-6 * length(n) * size) return;  // edge-on: no solid angle
    if (min(v_distance[0], min(v_distance[1], v_distance[2])) <= 0.0) return;
    float widest = max(edge_angle(c0, c1), max(edge_angle(c1, c2), edge_angle(c2, c0)));
    int split = clamp(int(ceil(widest / MAX_SUB_EDGE_ANGLE)), 1,
                      1 << int(v_caster_level[0] + 0.5));
    vec3 plane_normal = hemisphere_local(n, side);
    vec4 plane = vec4(plane_normal, dot(plane_normal, hemisphere_local(c0, side)));
    vec3 du = (c1 - c0) / float(split), dv = (c2 - c0) / float(split);
    // Row k lies between the lines j = k and j = k + 1 of the barycentric grid (j along c0->c2).
    for (int k = 0; k < split; ++k) {
        int cells = split - k;
        for (int i = 0; i < cells; ++i) {
            emit(c0 + float(i) * du + float(k + 1) * dv, side, plane);
            emit(c0 + float(i) * du + float(k) * dv, side, plane);
        }
        emit(c0 + float(cells) * du + float(k) * dv, side, plane);
        EndPrimitive();
    }
}
