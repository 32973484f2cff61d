#version 410
// One point per texel whose unshot energy has just been shot.
in vec2 in_texel;
uniform vec2 u_atlas_size;
void main() {
    gl_Position = vec4((in_texel + 0.5) / u_atlas_size * 2.0 - 1.0, 0.0, 1.0);
    gl_PointSize = 1.0;
}
