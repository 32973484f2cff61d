// Receiver pass shared by the patch and light shaders: each defines irradiance_at(), the
// irradiance a point gets from the current shooter (0 where hidden or facing away).
uniform sampler2D u_position;
uniform sampler2D u_normal;
uniform sampler2D u_level;     // subdivision level of the texel

layout(location = 0) out vec4 out_irradiance;  // added to the accumulated irradiance
layout(location = 1) out vec4 out_unshot;      // added to the unshot radiance

const float PI = 3.14159265358979;

float receiver_surface;   // the number of the texel's surface, for visible_from_eye()

// The irradiance at 'point'; 'near_side' > 0: the point is the sample point of a texel of that
// side in the shooter's near field.
vec3 irradiance_at(vec3 point, vec3 normal, float near_side);
// Whether the texel lies so close to the shooter that it gathers at its sample point only.
bool in_near_field(vec3 point, float texel_size);

void main() {
    ivec2 texel = ivec2(gl_FragCoord.xy);
    vec4 position = texelFetch(u_position, texel, 0);
    vec4 material = texelFetch(u_material, texel, 0);
    if (position.w <= 0.0 || material.a <= 0.0) discard;
    receiver_surface = decode_surface(material.a);
    vec3 normal = decode_normal(texelFetch(u_normal, texel, 0).xy);
    // A texel's side on the surface: its area's root (less than a texel edge at chart borders).
    float side = sqrt(position.w);
    // A subdivided texel gathers at split x split points spread over a square of its area
    // around its sample point (the part of the texel square its surface covers). Not next to
    // the shooter: a texel there re-shoots from its sample point, so light gathered over the
    // rest of its square (say in a gap behind an emitter) would leak out from there. There it
    // gathers at its sample point, or, across a thin gap with that point over the shooter's
    // surface, nothing here: the solver adds the gap's light (receive_patch.frag, near_side).
    float near_side = in_near_field(position.xyz, side) ? side : 0.0;
    int split = near_side > 0.0 ? 1 : 1 << decode_level(texelFetch(u_level, texel, 0).r);
    vec3 tangent = tangent_of(normal);
    vec3 bitangent = cross(normal, tangent);
    vec3 irradiance = vec3(0.0);
    // One loop and one call site: a second inlined copy of irradiance_at() cost llvmpipe
    // as much again per fragment, even where no texel took its branch.
    for (int k = 0; k < split * split; ++k) {
        vec2 offset = (vec2(k % split, k / split) + 0.5) / float(split) - 0.5;
        irradiance += irradiance_at(position.xyz + side * (offset.x * tangent
                                                           + offset.y * bitangent), normal,
                                    near_side);
    }
    irradiance /= float(split * split);
    if (irradiance.r + irradiance.g + irradiance.b <= 0.0) discard;
    // The irradiance gained by this texel and the reflected radiance it must shoot later.
    out_irradiance = vec4(irradiance, 0.0);
    out_unshot = vec4(material.rgb * irradiance / PI, 0.0);
}
