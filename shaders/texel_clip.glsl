// A triangle in lightmap texels (g_texel[0..2], from raster.geom) against one texel: the
// part of the texel square it covers and barycentrics.
#include "plane2d.glsl"

// The covered part's moments from one triangle edge, a to b, relative to the texel's
// corner (Green's theorem in columns): over the edge's run in x within [0, 1], the integrals
// of f, x f and f^2 / 2 for f = clamp(y, 0, 1), signed by the direction of the run. Summed
// over a closed outline they are minus the part's area and first moments: each column's
// crossings add f at the exits and take it at the entries, which leaves the length of the
// column within both shapes. Straight-line code: the polygon clipping it replaces indexed
// local arrays, which llvmpipe runs many times slower.
vec3 edge_moments(vec2 a, vec2 b) {
    float lo = max(min(a.x, b.x), 0.0);
    float hi = min(max(a.x, b.x), 1.0);
    if (lo >= hi) return vec3(0.0);   // outside the texel's columns, or a vertical edge
    // Where the edge's y crosses 0 and 1 (f bends there), within the run.
    float inverse_run = 1.0 / (b.x - a.x);
    float slope_x = (b.y != a.y) ? (b.x - a.x) / (b.y - a.y) : 0.0;
    float cross0 = (b.y != a.y) ? clamp(a.x - a.y * slope_x, lo, hi) : lo;
    float cross1 = (b.y != a.y) ? clamp(a.x + (1.0 - a.y) * slope_x, lo, hi) : lo;
    float xs[4] = float[4](lo, min(cross0, cross1), max(cross0, cross1), hi);
    float f[4];
    for (int i = 0; i < 4; ++i)
        f[i] = clamp(mix(a.y, b.y, clamp((xs[i] - a.x) * inverse_run, 0.0, 1.0)), 0.0, 1.0);
    vec3 sums = vec3(0.0);
    for (int i = 0; i < 3; ++i) {   // f is linear on each piece
        float width = xs[i + 1] - xs[i];
        sums += width * vec3(0.5 * (f[i] + f[i + 1]),
                             (xs[i] * (2.0 * f[i] + f[i + 1])
                              + xs[i + 1] * (f[i] + 2.0 * f[i + 1])) / 6.0,
                             (f[i] * f[i] + f[i] * f[i + 1] + f[i + 1] * f[i + 1]) / 6.0);
    }
    return (b.x > a.x) ? sums : -sums;
}

// The triangle against the unit texel square at 'origin': the covered area in texel units
// and the covered_centre of the covered part.
float clip_triangle_to_texel(vec2 origin, out vec2 covered_centre) {
    vec2 p0 = g_texel[0] - origin, p1 = g_texel[1] - origin, p2 = g_texel[2] - origin;
    vec3 moments = -(edge_moments(p0, p1) + edge_moments(p1, p2) + edge_moments(p2, p0));
    if (abs(moments.x) < 0.5e-12) { covered_centre = origin + 0.5; return 0.0; }
    covered_centre = origin + moments.yz / moments.x;
    return abs(moments.x);
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
