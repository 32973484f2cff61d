#version 410
// Receiver update for a point, spot or sun light (Blender's conventions, as Cycles renders
// them): irradiance I cos / d^2 from a point of intensity I, masked to a spot's cone, or S cos
// from a sun of strength S.
#include "projection.glsl"
#include "visibility_test.glsl"
#include "receiver_common.glsl"

uniform int u_light_kind;       // 0 point, 1 spot, 2 sun
uniform vec3 u_light_value;     // intensity (W/sr) for point and spot, irradiance for the sun
uniform vec3 u_spot_axis;       // direction the spot points to
uniform float u_spot_cos_half;  // cosine of half the cone angle
uniform float u_spot_smooth;    // width of the blend band in cosine units

bool in_near_field(vec3 point, float texel_size) {
    return false;  // point lights and suns have no extent
}

vec3 travel_direction(vec3 point) {
    return u_light_kind == 2 ? u_frame[2] : normalize(point - u_eye);
}

int shooter_count() { return 1; }   // one light per pass
// A light's shadow is sharp: over the texel's square. Not with a hemisphere projection's
// map, whose two halves meet at the light's horizon, where a point behind a wall saw the
// light through their seam.
bool pass_takes_squares() { return u_hemisphere == 0; }

bool select_shooter(int index) { return true; }

vec3 irradiance_at(vec3 point, vec3 normal, float near_side, float square_side) {
    vec3 irradiance;
    if (u_light_kind == 2) {
        float cos_r = -dot(normal, u_frame[2]);
        if (cos_r <= 0.0) return vec3(0.0);
        irradiance = u_light_value * cos_r;
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
        irradiance = u_light_value * mask * cos_r / dist2;
    }
    return irradiance * visible_over_texel(point, 0, pass_takes_squares());
}
