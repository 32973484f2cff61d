#version 410
// The unshot power a receiver pass's light would add on one tile of a page
// (receivers.update): each texel's gathered irradiance times what it reflects into the room
// and its area, summed and sent to the one pixel of the pass's total, where additive
// blending sums the tiles.
uniform sampler2D u_gathered;
uniform sampler2D u_position;   // area in .w
uniform sampler2D u_material;   // what the texel reflects into the room in .rgb
in vec4 in_box;          // x0, y0, x1, y1 in texels of the page
flat out vec4 v_power;   // W, RGB

void main() {
    ivec4 box = ivec4(in_box);
    vec3 power = vec3(0.0);
    for (int y = box.y; y < box.w; ++y) {
        for (int x = box.x; x < box.z; ++x) {
            ivec2 texel = ivec2(x, y);
            power += texelFetch(u_gathered, texel, 0).rgb * texelFetch(u_material, texel, 0).rgb
                * texelFetch(u_position, texel, 0).w;
        }
    }
    v_power = vec4(power, 0.0);
    gl_Position = vec4(0.0, 0.0, 0.0, 1.0);
}
