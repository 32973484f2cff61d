#version 410
// Stereographic projection per vertex (Coombe et al., Wallner 2008): one render per hemisphere,
// but edges stay straight in the map where they should be arcs — the projection's known error.
in vec3 in_position;
in float in_caster_level;  // subdivision level of the caster (read by the tessellating pass)
in float in_surface;
out vec4 v_front;        // projected into the +n hemisphere's disc
out vec4 v_back;         // projected into the -n hemisphere's disc
out float v_height_front; // height above each hemisphere's base plane (clips the other half)
out float v_height_back;
out float v_distance;
out vec3 v_local;
out float v_caster_level;
out float v_surface;

#include "projection.glsl"

void main() {
    vec3 local = to_local(in_position);
    vec3 front = hemisphere_local(local, 0);
    vec3 back = hemisphere_local(local, 1);
    v_front = vec4(stereographic(front), 0.0, 1.0);
    v_back = vec4(stereographic(back), 0.0, 1.0);
    v_height_front = front.z;
    v_height_back = back.z;
    v_distance = length(local);
    v_local = local;
    v_caster_level = in_caster_level;
    v_surface = in_surface;
    gl_Position = vec4(0.0);
}
