#version 410
layout(location = 0) out vec4 out_unshot;
void main() { out_unshot = vec4(0.0); }
