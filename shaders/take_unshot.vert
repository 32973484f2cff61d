#version 410
// One point per texel a shot changes in place, carrying the value blended into it: what the
// shot took from its unshot energy, or a thin gap's light (state.blend_points).
in vec2 in_texel;
in vec4 in_taken;
uniform vec2 u_atlas_size;
flat out vec4 v_taken;
void main() {
    gl_Position = vec4((in_texel + 0.5) / u_atlas_size * 2.0 - 1.0, 0.0, 1.0);
    gl_PointSize = 1.0;
    v_taken = in_taken;
}
