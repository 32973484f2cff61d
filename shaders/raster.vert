#version 410
// Lightmap-space rasterization: one vertex per triangle corner (triangle soup).
in vec2 in_texel;      // lightmap position in texels
in vec3 in_position;   // world position
in vec3 in_normal;     // shading normal
in vec2 in_tex_uv;     // albedo texture coordinates
in vec3 in_albedo;      // diffuse albedo the lightmap shows
in vec3 in_reflectance; // what the surface reflects into the room
in vec3 in_emission;   // radiance from the front face
in float in_receive;   // its surface's number when the triangle receives, else 0
in float in_roughness; // of the glossy layers (Scene.roughness)

out VertexData {
    vec2 texel;
    vec3 position;
    vec3 normal;
    vec2 tex_uv;
    vec3 albedo;
    vec3 reflectance;
    vec3 emission;
    float receive;
    float roughness;
} v;

void main() {
    v.texel = in_texel;
    v.position = in_position;
    v.normal = in_normal;
    v.tex_uv = in_tex_uv;
    v.albedo = in_albedo;
    v.reflectance = in_reflectance;
    v.emission = in_emission;
    v.receive = in_receive;
    v.roughness = in_roughness;
    gl_Position = vec4(0.0);
}
