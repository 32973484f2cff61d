// SPDX-License-Identifier: GPL-3.0-or-later
//
// GLSL (WebGL 2) that reads a Luxel lightmap texel of a MOZ_lightmap texture: RGBD, irradiance
// = pow(rgb, 2.2) / a (times MOZ_lightmap's intensity). The GPU would filter the encoded
// bytes, whose decoding is not linear: seams where a texel's divisor differs from its
// neighbour's. lightMapAt decodes the four texels around a point first, then weighs them.
export const RGBD_LIGHTMAP = `
vec3 decodeLightMapRGBD(const in vec4 texel) {
    return pow(texel.rgb, vec3(2.2)) / max(texel.a, 1.0 / 255.0);
}
vec3 lightMapAt(const in sampler2D map, const in vec2 uv) {
    ivec2 last = textureSize(map, 0) - 1;
    vec2 position = uv * vec2(last + 1) - 0.5;
    vec2 weight = fract(position);
    ivec2 corner = ivec2(floor(position));
    vec3 texels[4];
    for (int i = 0; i < 4; i++) {
        ivec2 at = clamp(corner + ivec2(i & 1, i >> 1), ivec2(0), last);
        texels[i] = decodeLightMapRGBD(texelFetch(map, at, 0));
    }
    return mix(mix(texels[0], texels[1], weight.x), mix(texels[2], texels[3], weight.x),
               weight.y);
}`;
