#version 410
// Lightmap value: reflected diffuse radiance rho * E / pi (the units contract), alpha 1 on
// occupied receiving texels; with the ambient term, plus rho times the unshot remainder's
// uniform radiance.
uniform sampler2D u_position;
uniform sampler2D u_material;   // albedo, a > 0 on receiving texels
uniform sampler2D u_irradiance;
uniform vec3 u_ambient;
layout(location = 0) out vec4 out_color;
void main() {
    ivec2 t = ivec2(gl_FragCoord.xy);
    vec4 material = texelFetch(u_material, t, 0);
    bool occupied = texelFetch(u_position, t, 0).w > 0.0 && material.a > 0.0;
    vec3 irradiance = texelFetch(u_irradiance, t, 0).rgb;
    out_color = occupied ? vec4(material.rgb * (irradiance / 3.14159265358979 + u_ambient), 1.0) : vec4(0.0);
}
