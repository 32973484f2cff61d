#version 410
// Receiver update for a shooting patch: every receiving texel visible from the shooter gains
// irradiance pi * L * F, with F the exact point-to-polygon form factor (Lambert's formula)
// of the shooter's quad clipped to the receiver's horizon: bounded however close they are.
// THIN_GAPS (0 or 1, defined by the solver): whether receivers across a thin gap gather the
// share of their square over the shooter (sandwiched()).
#include "projection.glsl"
#include "visibility_test.glsl"
#include "receiver_common.glsl"

uniform vec3 u_quad[4];        // shooter quad corners, world space
uniform vec3 u_centre;         // shooter centre
uniform vec3 u_radiance;       // unshot radiance leaving the front face (shooters are
                               // one-sided: a two-sided emitter shoots from a mirrored copy)
uniform vec4 u_surface_extent; // u min, u max, v min, v max of the shooter's surface along
                               // u_frame's tangent and bitangent, from u_centre
uniform float u_sandwich_gap;  // a gap under this share of a texel is a sandwich

float polygon_form_factor(vec3 p, vec3 n) {
    vec3 poly[5];
    int count = 0;
    for (int i = 0; i < 4; ++i) {
        vec3 a = u_quad[i] - p, b = u_quad[(i + 1) % 4] - p;
        float da = dot(a, n), db = dot(b, n);
        if (da >= 0.0) poly[count++] = a;
        if ((da >= 0.0) != (db >= 0.0)) poly[count++] = a + (b - a) * (da / (da - db));
    }
    if (count < 3) return 0.0;
    float sum = 0.0;
    for (int i = 0; i < count; ++i) {
        vec3 a = poly[i], b = poly[(i + 1) % count];
        float la = length(a), lb = length(b);
        if (la < 1e-9 || lb < 1e-9) continue;
        a /= la; b /= lb;
        vec3 g = cross(a, b);
        float s = length(g);
        if (s < 1e-12) continue;
        sum += atan(s, dot(a, b)) * dot(n, g) / s;
    }
    return min(abs(sum) / (2.0 * PI), 1.0);
}

bool in_near_field(vec3 point, float texel_size) {
    float reach = 0.5 * length(u_quad[2] - u_quad[0]) + 2.0 * texel_size;
    return distance(point, u_centre) < reach;
}

#include "plane2d.glsl"

// The share of a receiver's texel square (side 'side' around 'point', parallel to the shooter)
// over the shooter's quad: its mean form factor as the gap between them goes to 0.
float covered_share(vec3 point, vec3 normal, float side) {
    mat3x2 to_plane = transpose(mat2x3(u_frame[0], u_frame[1]));
    vec3 tangent = tangent_of(normal);
    vec2 half_t = 0.5 * side * (to_plane * tangent);
    vec2 half_b = 0.5 * side * (to_plane * cross(normal, tangent));
    vec2 centre = to_plane * (point - u_centre);
    vec2 poly[8], next[8];
    poly[0] = centre - half_t - half_b;
    poly[1] = centre + half_t - half_b;
    poly[2] = centre + half_t + half_b;
    poly[3] = centre - half_t + half_b;
    int count = 4;
    vec2 quad[4];
    for (int i = 0; i < 4; ++i) quad[i] = to_plane * (u_quad[i] - u_centre);
    float turn = sign(cross2(quad[1] - quad[0], quad[2] - quad[1]));
    for (int edge = 0; edge < 4; ++edge) {   // clip to each edge of the quad (convex)
        vec2 a = quad[edge], direction = quad[(edge + 1) % 4] - a;
        int kept = 0;
        for (int i = 0; i < count; ++i) {
            vec2 p = poly[i], q = poly[(i + 1) % count];
            float dp = turn * cross2(direction, p - a), dq = turn * cross2(direction, q - a);
            if (dp >= 0.0) next[kept++] = p;
            if ((dp >= 0.0) != (dq >= 0.0)) next[kept++] = p + (q - p) * (dp / (dp - dq));
        }
        count = kept;
        for (int i = 0; i < count; ++i) poly[i] = next[i];
    }
    float twice_area = 0.0;
    for (int i = 0; i < count; ++i) twice_area += cross2(poly[i], poly[(i + 1) % count]);
    return min(0.5 * abs(twice_area) / max(4.0 * abs(cross2(half_t, half_b)), 1e-30), 1.0);
}

// A receiver facing the shooter across a gap under u_sandwich_gap of its texel, its sample
// point over the shooter's surface (a ceiling 0.1 mm over a lamp's back, or 1 cm over an
// office lamp at 25 cm texels). At its sample point alone a texel gets all of a shooter over
// the point and none of one beside it: what it gets depends on how the two texel grids fall,
// and a texel half over a lamp got the whole lamp's light (the office's gaps made a quarter
// of its light). Not with the sample point beside the surface: light the texel's square
// gathered over the surface would be shot again from there, out of the gap.
bool sandwiched(vec3 from_shooter, float height, vec3 normal, float side) {
    vec2 at = vec2(dot(from_shooter, u_frame[0]), dot(from_shooter, u_frame[1]));
    return height < u_sandwich_gap * side && dot(normal, u_frame[2]) < -0.99
        && all(greaterThanEqual(at, u_surface_extent.xz))
        && all(lessThanEqual(at, u_surface_extent.yw));
}

vec3 irradiance_at(vec3 point, vec3 normal, float near_side) {
    vec3 from_shooter = point - u_centre;
    float height = dot(from_shooter, u_frame[2]);
    // Only what lies in front. The shooter's own plane gets nothing: Lambert's formula jumps
    // to 1 at a point inside a coplanar polygon, and rounding puts such points on either side.
    if (height <= u_epsilon || dot(normal, from_shooter) >= 0.0) return vec3(0.0);
    float visible = visible_from_eye(point, normal, receiver_surface);
    if (visible <= 0.0) return vec3(0.0);
#if THIN_GAPS
    float form_factor = near_side > 0.0 && sandwiched(from_shooter, height, normal, near_side)
        ? covered_share(point, normal, near_side) : polygon_form_factor(point, normal);
#else
    float form_factor = polygon_form_factor(point, normal);
#endif
    return PI * u_radiance * form_factor * visible;
}
