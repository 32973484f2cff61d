#version 410
// Blended into the texel: subtracted from the unshot energy, or added to the irradiance.
flat in vec4 v_taken;
layout(location = 0) out vec4 out_taken;
void main() { out_taken = v_taken; }
