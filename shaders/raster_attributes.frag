#version 410
// Surface attributes per texel. A texel whose centre lies inside the triangle samples there;
// a texel the triangle covers only partly samples at the covered_centre of the covered part, so
// chart borders carry real surface values (no dark rims). Depth prefers the triangle that
// holds the centre, then the one covering most of the texel.
flat in vec2 g_texel[3];
flat in vec3 g_position[3];
flat in vec3 g_normal[3];
flat in vec2 g_tex_uv[3];
flat in vec3 g_albedo;
flat in vec3 g_reflectance;
flat in vec3 g_emission;
flat in float g_receive;
flat in float g_roughness;
flat in vec3 g_face_normal;
flat in float g_texel_size;
flat in float g_area_per_texel;

uniform sampler2D u_albedo_texture;
uniform int u_use_texture;
uniform sampler2D u_emission_texture;     // multiplies the emission, as the albedo's its
uniform int u_use_emission_texture;
uniform sampler2D u_reflectance_texture;
uniform int u_use_reflectance_texture;

layout(location = 0) out vec4 out_position;  // xyz, w = texel area (added by the area pass)
layout(location = 1) out vec4 out_normal;    // octahedral normal (texel_maps.glsl), and the
                                             // spread of a flat texel (preprocess.measure_surface)
layout(location = 2) out vec4 out_material;  // reflectance (what the texel reflects into the
                                             // room), a = the receiving surface's number
layout(location = 3) out vec4 out_unshot;    // emitted radiance (the first unshot), a = world
                                             // length of a texel edge
layout(location = 4) out vec4 out_albedo;    // the diffuse albedo the lightmap shows, a = the
                                             // glossy layers' roughness

#include "texel_maps.glsl"
#include "texel_clip.glsl"
#include "shading_normal.glsl"

void main() {
    vec2 origin = floor(gl_FragCoord.xy);
    vec2 covered_centre;
    float covered = clip_triangle_to_texel(origin, covered_centre);
    if (covered <= 1e-7) discard;

    vec2 centre = origin + 0.5;
    vec3 w = barycentric(centre);
    vec2 sample_point = centre;
    float depth = 0.0;
    if (min(w.x, min(w.y, w.z)) < 0.0) {
        sample_point = covered_centre;
        w = covered_barycentric(covered_centre);
        depth = 0.5 + 0.49 * (1.0 - min(covered, 1.0));
    }
    gl_FragDepth = depth;

    vec3 position = w.x * g_position[0] + w.y * g_position[1] + w.z * g_position[2];
    vec3 normal = shading_normal(w);

    vec2 uv = w.x * g_tex_uv[0] + w.y * g_tex_uv[1] + w.z * g_tex_uv[2];
    vec3 albedo = g_albedo;
    if (u_use_texture != 0) albedo *= texture(u_albedo_texture, uv).rgb;
    vec3 reflectance = g_reflectance;
    if (u_use_reflectance_texture != 0) reflectance *= texture(u_reflectance_texture, uv).rgb;
    vec3 emission = g_emission;
    if (u_use_emission_texture != 0) emission *= texture(u_emission_texture, uv).rgb;

    out_position = vec4(position, 0.0);
    out_normal = vec4(encode_normal(normal), 1.0, 0.0);
    out_material = vec4(reflectance, encode_surface(g_receive));
    out_albedo = vec4(albedo, g_roughness);
    out_unshot = vec4(emission, g_texel_size);
}
