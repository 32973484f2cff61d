#version 410
// Gutter fill: an empty texel takes the mean of its filled neighbours, so bilinear sampling
// across chart borders shows no seams. Alpha: 1 occupied, 0.5 filled gutter, 0 empty.
uniform sampler2D u_source;
layout(location = 0) out vec4 out_color;
void main() {
    ivec2 t = ivec2(gl_FragCoord.xy);
    ivec2 size = textureSize(u_source, 0);
    vec4 own = texelFetch(u_source, t, 0);
    if (own.a > 0.0) { out_color = own; return; }
    vec3 sum = vec3(0.0);
    float count = 0.0;
    for (int j = -1; j <= 1; ++j) {
        for (int i = -1; i <= 1; ++i) {
            ivec2 n = t + ivec2(i, j);
            if (n.x < 0 || n.y < 0 || n.x >= size.x || n.y >= size.y) continue;
            vec4 s = texelFetch(u_source, n, 0);
            if (s.a > 0.0) { sum += s.rgb; count += 1.0; }
        }
    }
    out_color = count > 0.0 ? vec4(sum / count, 0.5) : vec4(0.0);
}
