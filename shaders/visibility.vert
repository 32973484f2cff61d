#version 410
in vec3 in_position;
out vec3 v_world;
void main() {
    v_world = in_position;
    gl_Position = vec4(0.0);
}
