// A triangle in lightmap texels (g_texel[0..2], from raster.geom) against one texel: the
// part of the texel square it covers and barycentrics.
#include "plane2d.glsl"

// Clip the triangle against the unit texel square at 'origin'. Returns the covered area in
// texel units and the covered_centre of the covered part.
float clip_triangle_to_texel(vec2 origin, out vec2 covered_centre) {
    vec2 poly[9];
    vec2 next_poly[9];
    int count = 3;
    for (int i = 0; i < 3; ++i) poly[i] = g_texel[i] - origin;
    // Four half-planes: x >= 0, x <= 1, y >= 0, y <= 1.
    for (int plane = 0; plane < 4; ++plane) {
        int axis = plane / 2;
        float sgn = (plane % 2 == 0) ? 1.0 : -1.0;
        float offset = (plane % 2 == 0) ? 0.0 : 1.0;
        int out_count = 0;
        for (int i = 0; i < count; ++i) {
            vec2 a = poly[i], b = poly[(i + 1) % count];
            float da = sgn * (a[axis] - offset);
            float db = sgn * (b[axis] - offset);
            if (da >= 0.0) next_poly[out_count++] = a;
            if ((da >= 0.0) != (db >= 0.0)) next_poly[out_count++] = a + (b - a) * (da / (da - db));
        }
        count = out_count;
        for (int i = 0; i < count; ++i) poly[i] = next_poly[i];
        if (count < 3) { covered_centre = vec2(0.5); return 0.0; }
    }
    float area2 = 0.0;
    vec2 c = vec2(0.0);
    for (int i = 0; i < count; ++i) {
        vec2 a = poly[i], b = poly[(i + 1) % count];
        float w = cross2(a, b);
        area2 += w;
        c += (a + b) * w;
    }
    if (abs(area2) < 1e-12) { covered_centre = vec2(0.5); return 0.0; }
    covered_centre = origin + c / (3.0 * area2);
    return abs(area2) * 0.5;
}

vec3 barycentric(vec2 p) {
    vec2 a = g_texel[0], b = g_texel[1], c = g_texel[2];
    float total = cross2(b - a, c - a);
    float wa = cross2(b - p, c - p) / total;
    float wb = cross2(c - p, a - p) / total;
    return vec3(wa, wb, 1.0 - wa - wb);
}

// Barycentrics of the covered_centre of a texel the triangle covers only partly: the
// triangle's nearest point to it (rounding puts it just outside).
vec3 covered_barycentric(vec2 covered_centre) {
    vec3 w = clamp(barycentric(covered_centre), 0.0, 1.0);
    return w / (w.x + w.y + w.z);
}
