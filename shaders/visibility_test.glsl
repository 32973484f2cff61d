// Back-projection of a receiver into the visibility map and depth comparison.
uniform sampler2DArray u_visibility;
uniform float u_resolution;
uniform float u_epsilon;  // absolute depth tolerance, scaled to the scene

// 1 when 'world' (a receiver with normal 'normal') is the nearest surface seen from the eye.
float visible_from_eye(vec3 world, vec3 normal) {
    vec3 local = to_local(world);
    int face = face_of(local);
    vec4 clip = face_clip(local, face);
    vec2 uv = clip.xy / clip.w * 0.5 + 0.5;
    ivec2 texel = clamp(ivec2(uv * u_resolution), ivec2(0), ivec2(int(u_resolution) - 1));
    float stored = texelFetch(u_visibility, ivec3(texel, face), 0).r;
    float own = view_distance(local);
    // Slope-scaled tolerance: across one visibility texel a surface seen at a grazing angle
    // changes its distance by about texel footprint * tan(angle).
    vec3 to_eye = u_orthographic != 0 ? -(u_frame[2]) : -normalize(u_frame * local);
    float cos_incidence = clamp(abs(dot(normal, to_eye)), 0.02, 1.0);
    float tan_incidence = sqrt(1.0 - cos_incidence * cos_incidence) / cos_incidence;
    float footprint = u_orthographic != 0 ? 2.0 * u_ortho_half / u_resolution
                                          : own * 2.0 / u_resolution;
    float tolerance = u_epsilon + footprint * min(tan_incidence, 8.0) * 1.5;
    return own <= stored + tolerance ? 1.0 : 0.0;
}
