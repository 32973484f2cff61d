// Back-projection of a receiver into the visibility map and depth comparison.
uniform sampler2DArray u_visibility;
uniform float u_resolution;
uniform float u_epsilon;             // absolute depth tolerance, scaled to the scene
uniform int u_neighbour_visibility;  // the paper's fix (Sec. 5.2): any of the 3x3 texels may see it

// 1 when 'world' (a receiver with normal 'normal') is the nearest surface seen from the eye.
float visible_from_eye(vec3 world, vec3 normal) {
    vec3 local = to_local(world);
    float own = view_distance(local);
    int last = int(u_resolution) - 1;
    ivec3 texel;
    float footprint;  // world size of one map texel at the receiver
    if (u_hemisphere != 0 && u_orthographic == 0) {
        int side = local.z >= 0.0 ? 0 : 1;
        vec3 h = hemisphere_local(local, side);
        vec2 uv = stereographic(h) * 0.5 + 0.5;
        texel = ivec3(clamp(ivec2(uv * u_resolution), ivec2(0), ivec2(last)), side);
        // d(disc)/d(angle) = 1 / (1 + cos): a texel spans 2 (1 + cos) / resolution radians.
        footprint = own * 2.0 * (1.0 + h.z / max(own, 1e-30)) / u_resolution;
    } else {
        int face = face_of(local);
        vec4 clip = face_clip(local, face);
        vec2 uv = clip.xy / clip.w * 0.5 + 0.5;
        texel = ivec3(clamp(ivec2(uv * u_resolution), ivec2(0), ivec2(last)), face);
        footprint = u_orthographic != 0 ? 2.0 * u_ortho_half / u_resolution
                                        : own * 2.0 / u_resolution;
    }
    float stored = texelFetch(u_visibility, texel, 0).r;
    if (u_neighbour_visibility != 0) {
        // Glancing silhouettes: the receiver may fall on the occluder's side of a texel edge.
        for (int j = -1; j <= 1; ++j) {
            for (int i = -1; i <= 1; ++i) {
                ivec2 n = clamp(texel.xy + ivec2(i, j), ivec2(0), ivec2(last));
                stored = max(stored, texelFetch(u_visibility, ivec3(n, texel.z), 0).r);
            }
        }
    }
    // Slope-scaled tolerance: across one visibility texel a surface seen at a grazing angle
    // changes its distance by about texel footprint * tan(angle).
    vec3 to_eye = u_orthographic != 0 ? -(u_frame[2]) : -normalize(u_frame * local);
    float cos_incidence = clamp(abs(dot(normal, to_eye)), 0.02, 1.0);
    float tan_incidence = sqrt(1.0 - cos_incidence * cos_incidence) / cos_incidence;
    float tolerance = u_epsilon + footprint * min(tan_incidence, 8.0) * 1.5;
    return own <= stored + tolerance ? 1.0 : 0.0;
}
