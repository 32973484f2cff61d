#version 410
in vec3 in_position;
in float in_surface;
out vec3 v_world;
out float v_surface;
void main() {
    v_world = in_position;
    v_surface = in_surface;
    gl_Position = vec4(0.0);
}
