#version 410
// Receiver update for a point, spot or sun light (Blender's conventions, as Cycles renders
// them): irradiance I cos / d^2 from a point of intensity I, masked to a spot's cone, or S cos
// from a sun of strength S. Suns come in batches (the sky's many), gathered one after another
// per texel in one pass, each against its own visibility map: its window's u_sun_tiles^2
// layers from u_sun_tiles^2 x its index; a point or spot light alone.
#define VIEW_PER_SHOOTER
#include "projection.glsl"
#include "visibility_test.glsl"
#include "receiver_common.glsl"

// MOST_SHOOTERS, defined where the program is made (preprocess.create_programs), is the
// bake's batch size (memory.receiver_batch).
uniform int u_light_count;      // this pass's, up to MOST_SHOOTERS (1 but for suns)
uniform int u_light_kind;       // 0 point, 1 spot, 2 sun: the pass's
uniform vec3 u_light_values[MOST_SHOOTERS];  // intensity (W/sr) for point and spot,
                                             // irradiance for a sun
uniform vec3 u_eyes[MOST_SHOOTERS];          // where each light's map was drawn from
uniform mat3 u_frames[MOST_SHOOTERS];        // and its frame (columns t, b, n)
uniform vec3 u_spot_axis;       // direction the spot points to
uniform float u_spot_cos_half;  // cosine of half the cone angle
uniform float u_spot_smooth;    // width of the blend band in cosine units

// The current light (select_shooter).
int light;

bool in_near_field(vec3 point, float texel_size) {
    return false;  // point lights and suns have no extent
}

vec3 travel_direction(vec3 point) {
    return u_light_kind == 2 ? u_frame[2] : normalize(point - u_eye);
}

// A batch of one is known here: the pass then compiles without the loop over lights.
int shooter_count() { return MOST_SHOOTERS == 1 ? 1 : u_light_count; }
// A light's shadow is sharp: over the texel's square. Not with a hemisphere projection's
// map, whose two halves meet at the light's horizon, where a point behind a wall saw the
// light through their seam.
bool pass_takes_squares() { return u_hemisphere == 0; }

bool select_shooter(int index) {
    light = index;
    u_eye = u_eyes[index];
    u_frame = u_frames[index];
    return true;
}

vec3 irradiance_at(vec3 point, vec3 normal, float near_side, float square_side) {
    vec3 irradiance;
    if (u_light_kind == 2) {
        float cos_r = -dot(normal, u_frame[2]);
        if (cos_r <= 0.0) return vec3(0.0);
        irradiance = u_light_values[light] * cos_r;
    } else {
        vec3 d = point - u_eye;
        float dist2 = dot(d, d);
        vec3 dir = d / sqrt(dist2);
        float cos_r = -dot(normal, dir);
        if (cos_r <= 0.0) return vec3(0.0);
        float mask = 1.0;
        if (u_light_kind == 1) {
            float c = dot(dir, u_spot_axis);
            if (c <= u_spot_cos_half) return vec3(0.0);
            if (u_spot_smooth > 0.0) mask = smoothstep(0.0, 1.0, (c - u_spot_cos_half) / u_spot_smooth);
        }
        irradiance = u_light_values[light] * mask * cos_r / dist2;
    }
    return irradiance * visible_over_texel(point, u_sun_tiles * u_sun_tiles * light,
                                           pass_takes_squares());
}
