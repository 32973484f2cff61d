#version 410
// All faces of the visibility cube in one pass: one geometry-shader invocation per face,
// each routed to its layer. A front-only shooter clips geometry behind its plane.
layout(triangles, invocations = 6) in;
layout(triangle_strip, max_vertices = 3) out;

uniform int u_face_count;
uniform int u_clip_below;

in vec3 v_world[];
in float v_surface[];
out vec3 g_local;
flat out float g_surface;
flat out int g_faces_away;

#include "visibility_store.glsl"

#include "projection.glsl"

void main() {
    if (gl_InvocationID >= u_face_count) return;
    bool away = faces_away_from_eye(to_local(v_world[0]), to_local(v_world[1]),
                                    to_local(v_world[2]));
    for (int i = 0; i < 3; ++i) {
        vec3 local = to_local(v_world[i]);
        g_local = local;
        g_surface = v_surface[0];
        g_faces_away = int(away);
        gl_Position = face_clip(local, gl_InvocationID);
        gl_ClipDistance[0] = u_clip_below != 0 ? local.z : 1.0;
        gl_Layer = gl_InvocationID;
        EmitVertex();
    }
    EndPrimitive();
}
