#version 410
// One step of the arg-max pyramid: each output texel keeps the strongest of its 2x2 sources
// (power, x, y) and the sum of their powers in .w. Sources outside the image are skipped.
uniform sampler2D u_source;
layout(location = 0) out vec4 out_best;

void main() {
    ivec2 size = textureSize(u_source, 0);
    ivec2 base = ivec2(gl_FragCoord.xy) * 2;
    vec4 best = vec4(-1.0, 0.0, 0.0, 0.0);
    float total = 0.0;
    for (int j = 0; j < 2; ++j) {
        for (int i = 0; i < 2; ++i) {
            ivec2 t = base + ivec2(i, j);
            if (t.x >= size.x || t.y >= size.y) continue;
            vec4 s = texelFetch(u_source, t, 0);
            total += s.w;
            if (s.x > best.x) best = s;
        }
    }
    out_best = vec4(best.xyz, total);
}
