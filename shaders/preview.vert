#version 410
// Camera view of the scene with its lightmaps, for previews.
in vec3 in_position;
in vec3 in_lightmap;   // uv on the page, page index (-1: no lightmap)
in vec4 in_emission;   // rgb radiance, a = emits from both faces
uniform mat4 u_view_projection;
out vec3 v_lightmap;
flat out vec4 v_emission;
void main() {
    v_lightmap = in_lightmap;
    v_emission = in_emission;
    gl_Position = u_view_projection * vec4(in_position, 1.0);
}
