#version 410
flat in vec4 v_power;
layout(location = 0) out vec4 out_power;

void main() { out_power = v_power; }
