#version 410
// Unshot power of every block of u_block x u_block texels (the shooting mip level), masked to
// occupied texels. Output (power, block x, block y, power): the first level of the arg-max
// pyramid, whose .w carries the sum.
uniform sampler2D u_position;
uniform sampler2D u_unshot;
uniform int u_block;
layout(location = 0) out vec4 out_power;

void main() {
    ivec2 block = ivec2(gl_FragCoord.xy);
    ivec2 size = textureSize(u_position, 0);
    ivec2 base = block * u_block;
    float power = 0.0;
    for (int j = 0; j < u_block; ++j) {
        for (int i = 0; i < u_block; ++i) {
            ivec2 t = base + ivec2(i, j);
            if (t.x >= size.x || t.y >= size.y) continue;
            float area = texelFetch(u_position, t, 0).w;
            if (area <= 0.0) continue;
            vec3 radiance = texelFetch(u_unshot, t, 0).rgb;
            power += (radiance.r + radiance.g + radiance.b) * area;
        }
    }
    power *= 3.14159265358979 / 3.0;
    out_power = vec4(power, vec2(block), power);
}
