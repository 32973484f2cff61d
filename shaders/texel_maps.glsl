// The compact per-texel maps (allocate_page in native/preprocess.py): the normal
// octahedral in two 16-bit normalized channels, with 0 and +-1 exact so that axis-aligned
// surfaces keep exact normals; a receiving surface's number and the subdivision level as
// integers in normalized channels. Stored integers carry +0.25 so that a driver that
// truncates instead of rounding stores the same integer.
const float OCT_STEPS = 32767.0;

vec2 sign_not_zero(vec2 v) {
    return vec2(v.x >= 0.0 ? 1.0 : -1.0, v.y >= 0.0 ? 1.0 : -1.0);
}

vec2 encode_normal(vec3 n) {
    vec2 p = n.xy / (abs(n.x) + abs(n.y) + abs(n.z));
    if (n.z < 0.0) p = (1.0 - abs(p.yx)) * sign_not_zero(p);
    return (p * OCT_STEPS + OCT_STEPS + 0.25) / 65535.0;
}

vec3 decode_normal(vec2 stored) {
    vec2 p = (floor(stored * 65535.0 + 0.5) - OCT_STEPS) / OCT_STEPS;
    vec3 n = vec3(p, 1.0 - abs(p.x) - abs(p.y));
    if (n.z < 0.0) n.xy = (1.0 - abs(n.yx)) * sign_not_zero(n.xy);
    return normalize(n);
}

float encode_surface(float surface) { return (surface + 0.25) / 65535.0; }
// A texel receives light where it holds surface (an area, in the position map's .w) of a
// receiving surface (a number above 0, in the material map's .a).
bool receives(vec4 position, vec4 material) { return position.w > 0.0 && material.a > 0.0; }
float decode_surface(float stored) { return floor(stored * 65535.0 + 0.5); }

float encode_level(float level) { return (level + 0.25) / 255.0; }
int decode_level(float stored) { return int(stored * 255.0 + 0.5); }

// A unit tangent of the normal n, the same for every texel of a plane: along a world axis
// for an axis-aligned surface.
vec3 tangent_of(vec3 n) {
    vec3 a = abs(n);
    vec3 axis = (a.x <= a.y && a.x <= a.z) ? vec3(1.0, 0.0, 0.0)
              : (a.y <= a.z ? vec3(0.0, 1.0, 0.0) : vec3(0.0, 0.0, 1.0));
    return normalize(axis - n * dot(axis, n));
}

// A texel whose surface bends within it (preprocess.measure_surface) keeps its sample's normal n
// in the first two channels, the spread of its normals (the mean normal's length, 1 on a flat
// texel) in the third, and in the fourth, 8 bits each, the heading of a tangent of n (from
// tangent_of(n) towards n x tangent_of(n)) and the tilt from n along it to the mean normal
// (preprocess.bent_normal_codes). Gives the mean normal's direction and the axis, at it, along which
// the normals vary most.
const float BEND_STEPS = 255.0;

void decode_bend(vec3 n, float stored, out vec3 mean, out vec3 axis) {
    float code = floor(stored * 65535.0 + 0.5);
    float heading = (floor(code / (BEND_STEPS + 1.0)) / BEND_STEPS - 0.5) * 6.28318530717959;
    float tilt = mod(code, BEND_STEPS + 1.0) / BEND_STEPS * 1.5707963267949;
    vec3 t = tangent_of(n);
    vec3 towards = cos(heading) * t + sin(heading) * cross(n, t);
    mean = cos(tilt) * n + sin(tilt) * towards;
    axis = cos(tilt) * towards - sin(tilt) * n;
}
