#version 410
// The power a receiver pass's light brings to one tile of a page (receivers.update): each
// receiving texel's gathered irradiance times the area whose received light is its own
// (state.Page.own_area: less where faces drawn over each other share it), and times its
// area and what it reflects into the room (the unshot power it would add), summed and sent to the one pixel
// of the pass's totals, where additive blending sums the tiles. The gathered map holds what
// the last pass that drew a texel left there: texels that do not receive are skipped.
#include "texel_maps.glsl"
uniform sampler2D u_gathered;
uniform sampler2D u_position;   // area in .w
uniform sampler2D u_material;   // what the texel reflects into the room in .rgb
uniform sampler2D u_own_area;
in vec4 in_box;              // x0, y0, x1, y1 in texels of the page
flat out vec3 v_received;    // W, RGB
flat out vec3 v_reflected;

void main() {
    ivec4 box = ivec4(in_box);
    v_received = vec3(0.0);
    v_reflected = vec3(0.0);
    for (int y = box.y; y < box.w; ++y) {
        for (int x = box.x; x < box.z; ++x) {
            ivec2 texel = ivec2(x, y);
            vec4 position = texelFetch(u_position, texel, 0);
            vec4 material = texelFetch(u_material, texel, 0);
            if (!receives(position, material)) continue;
            vec3 irradiance = texelFetch(u_gathered, texel, 0).rgb;
            v_received += irradiance * texelFetch(u_own_area, texel, 0).r;
            v_reflected += irradiance * material.rgb * position.w;
        }
    }
    gl_Position = vec4(0.0, 0.0, 0.0, 1.0);
}
