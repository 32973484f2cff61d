#version 410
// The receiver pass draws the texel boxes of the charts that can receive the shot
// (receivers.py), given in texels of the page.
uniform vec2 u_atlas_size;
in vec2 in_corner;

void main() {
    gl_Position = vec4(in_corner / u_atlas_size * 2.0 - 1.0, 0.0, 1.0);
}
