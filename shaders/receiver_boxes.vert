#version 410
// The receiver pass draws the texel boxes of the tiles that can receive the shot
// (receivers.py), given in texels of the page, each with the shooters it can receive from.
uniform vec2 u_atlas_size;
in vec2 in_corner;
in float in_shooters;      // a bit per shooter of the pass
flat out int v_shooters;

void main() {
    gl_Position = vec4(in_corner / u_atlas_size * 2.0 - 1.0, 0.0, 1.0);
    v_shooters = int(in_shooters);
}
