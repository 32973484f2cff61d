// Receiver texel data shared by the patch and light receiver passes.
uniform sampler2D u_position;
uniform sampler2D u_normal;
uniform sampler2D u_albedo;

layout(location = 0) out vec4 out_irradiance;  // added to the accumulated irradiance
layout(location = 1) out vec4 out_unshot;      // added to the unshot radiance

const float PI = 3.14159265358979;

// Writes the irradiance gained by this texel and the reflected radiance it must shoot later.
void deposit(vec3 irradiance, vec3 albedo) {
    out_irradiance = vec4(irradiance, 0.0);
    out_unshot = vec4(albedo * irradiance / PI, 0.0);
}
