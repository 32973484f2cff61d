#version 410
#extension GL_ARB_shader_viewport_layer_array : require
// One face of the visibility cube per draw, routed to its layer without a geometry shader
// (llvmpipe runs those on the calling thread): the caller draws only the clusters of
// triangles that can reach the face. A front-only shooter clips geometry behind its plane.
in vec3 in_position;
in float in_surface;

uniform int u_face;
uniform int u_clip_below;
uniform int u_first_layer;   // the shooter's map in a batch's (visibility.render)

out vec3 g_local;
flat out float g_surface;

#include "projection.glsl"

void main() {
    vec3 local = to_local(in_position);
    g_local = local;
    g_surface = in_surface;
    gl_Position = face_clip(local, u_face);
    gl_ClipDistance[0] = u_clip_below != 0 ? local.z : 1.0;
    gl_Layer = u_first_layer + u_face;
}
