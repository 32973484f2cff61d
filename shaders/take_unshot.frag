#version 410
// Subtracted from the unshot energy by reverse-subtract blending.
flat in vec4 v_taken;
layout(location = 0) out vec4 out_taken;
void main() { out_taken = v_taken; }
