#version 410
flat in float v_covered;
layout(location = 0) out vec4 out_covered;

void main() {
    out_covered = vec4(v_covered);
}
