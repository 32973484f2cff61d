#version 410
flat in vec3 v_received;
flat in vec3 v_reflected;
layout(location = 0) out vec4 out_received;
layout(location = 1) out vec4 out_reflected;

void main() {
    out_received = vec4(v_received, 0.0);
    out_reflected = vec4(v_reflected, 0.0);
}
