// Back-projection of a receiver into the visibility map and depth comparison.
#include "texel_maps.glsl"

uniform sampler2DArray u_visibility;
uniform sampler2D u_material;        // a receiving texel's alpha: its surface's number
uniform float u_resolution;
uniform float u_epsilon;             // absolute depth tolerance, scaled to the scene
uniform int u_neighbour_visibility;  // the paper's fix (Sec. 5.2): the 3x3 texels around vote
uniform int u_emitting_surfaces;     // surfaces 1..this emit

// The ray the map sampled at a texel's centre, in the eye's frame: origin (non-zero only for
// the sun's parallel rays) and unit direction.
void texel_ray(ivec3 texel, out vec3 origin, out vec3 direction) {
    vec2 p = (vec2(texel.xy) + 0.5) / u_resolution * 2.0 - 1.0;
    origin = vec3(0.0);
    if (u_orthographic != 0) {
        origin = vec3(sun_tile_middle(texel.z) + p * sun_tile_half(), 0.0);
        direction = vec3(0.0, 0.0, 1.0);
    } else if (u_hemisphere != 0) {
        direction = hemisphere_local(inverse_stereographic(p), texel.z);
    } else {
        direction = normalize(FACE_RIGHT[texel.z] * p.x + FACE_UP[texel.z] * p.y
                              + FACE_FORWARD[texel.z]);
    }
}

// The tolerances a receiver is given against the map: 'own_surface' (slope-scaled) where the
// nearest surface stored is the receiver's own smooth patch, 'other' (rounding only) where it
// is something else, and 'reach', how far from the receiver the map texel's ray may meet the
// receiver's plane.
struct Tolerance {
    float own_surface;
    float other;
    float reach;
};

// Whether the map texel, holding 'stored_texel' (visibility_store.glsl), lets the receiver
// (local point, local normal, distance 'own', its surface's number) be seen. Either its own
// distance is within the tolerance of the stored one, or the texel's centre ray meets the
// receiver's plane at the stored distance and near the receiver: a receiver seen at a
// grazing angle then never shadows itself, however steep, while a wall's far side, or the
// same floor past a wall, stays dark.
bool texel_sees(ivec3 texel, vec2 stored_texel, vec3 point, vec3 normal, float own,
                uint surface, Tolerance tolerance, bool overhung) {
    float stored = stored_texel.r;
    uint stored_key = floatBitsToUint(stored_texel.g) & 0x1FFFu;
    uint stored_surface = stored_key & 0xFFFu;
    bool same_surface = stored_surface == (surface & 0xFFFu);
    vec3 origin, direction;
    texel_ray(texel, origin, direction);
    float facing = dot(normal, direction);
    float along = facing != 0.0 ? dot(normal, point - origin) / facing : -1.0;
    // An emitter in the plane of a receiver that does not emit, over it (a lamp drawn in
    // the ceiling), takes the light: both receiving it would make energy. Coincident faces
    // that both emit, or neither, share the light by their areas (buried.py).
    bool receiver_emits = (surface & 0xFFFu) <= uint(u_emitting_surfaces);
    if (!same_surface && !receiver_emits && stored_key >= 1u
        && stored_key <= uint(u_emitting_surfaces) && abs(along - stored) <= u_epsilon)
        return false;
    // A ray that reaches the receiver's depth unblocked sees it; but where what hides the
    // receiver's own map texel stands in front of its plane ('overhung': a roof over a
    // wall's top, the step above), not one that met the plane before that depth: it passed
    // the overhang's edge in the open and reached the depth on the far side of the surface.
    bool crossed_in_the_open = facing < 0.0 && along < own - tolerance.other;
    if ((!overhung || !crossed_in_the_open) && own <= stored + tolerance.other) return true;
    // The own surface, seen where the map texel's ray meets it near the receiver: a floor
    // seen past a wall standing on it is the same surface, but not near.
    if (same_surface && own <= stored + tolerance.own_surface
        && distance(origin + stored * direction, point) <= tolerance.reach) return true;
    if (facing == 0.0) return false;
    // Only where the map holds a surface at that meeting point, in the receiver's plane:
    // a ray past the edge of the receiver's surface (a step under the next one, a wall's top
    // under a roof) meets the plane in the open, and lit what the edge shadows.
    return along > 0.0 && abs(along - stored) <= u_epsilon
        && distance(origin + along * direction, point) <= tolerance.reach;
}

// The last visible_from_eye()'s own map texel and the distance it holds, for
// blocker_height().
ivec3 last_map_texel;
float last_map_distance;

// How far in front of the plane of a receiver ('world', 'normal') lies the surface that
// visible_from_eye() just found in its own map texel: where it is hidden, what hides it.
float blocker_height(vec3 world, vec3 normal) {
    vec3 origin, direction;
    texel_ray(last_map_texel, origin, direction);
    return dot(transpose(u_frame) * normal,
               origin + last_map_distance * direction - to_local(world));
}

// How much of 'world' (a receiver with normal 'normal' on the surface numbered 'surface')
// the eye sees: 1 when it is the nearest surface in its direction. The eye's map starts at
// layer 'first_layer' (a batch of shooters keeps one map each, one after another).
float visible_from_eye(vec3 world, vec3 normal, float surface, int first_layer) {
    vec3 local = to_local(world);
    vec3 local_normal = transpose(u_frame) * normal;
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
        footprint = u_orthographic != 0 ? 2.0 * sun_tile_half() / u_resolution
                                        : own * 2.0 / u_resolution;
    }
    // Slope-scaled tolerance: across one visibility texel a surface seen at a grazing angle
    // changes its distance by about texel footprint * tan(angle). Only against the receiver's
    // own surface: against another (a wall it touches) it would let light through.
    vec3 to_eye = u_orthographic != 0 ? -(u_frame[2]) : -normalize(u_frame * local);
    float cos_incidence = clamp(abs(dot(normal, to_eye)), 0.02, 1.0);
    float tan_incidence = sqrt(1.0 - cos_incidence * cos_incidence) / cos_incidence;
    // On the receiver's plane a map texel's footprint stretches by 1 / cos; the receiver's
    // own texel's ray meets it within that (the 3x3 texels around, only through the depth).
    Tolerance tolerance = Tolerance(u_epsilon + footprint * min(tan_incidence, 8.0) * 1.5,
                                    u_epsilon,
                                    1.0 * footprint / cos_incidence);
    uint own_surface = uint(surface);
    // The receiver's own map texel first. If it fails, the receiver may be at a glancing
    // silhouette, the occluder's edge covering the texel's centre but not the receiver: it
    // gets the share of the 3x3 texels around that see it. Only where the occluder comes
    // within twice a map texel's reach of the receiver, as the surface it stands against
    // does (a block's top over its side, a wall at a floor's foot): a shadow cast from
    // farther is sharp in the map, and the vote would only light its edge. Not widened by
    // the occluder's slope across the 3x3: a board across a slot a few centimetres wide,
    // seen at a grazing angle, changes its distance by a reach from texel to texel, and the
    // vote lit the slot's shadowed side. One loop and one call site of texel_sees(), for
    // llvmpipe's sake as in receiver_common.glsl.
    float seen = 0.0;
    bool overhung = false;
    int last_neighbour = u_neighbour_visibility != 0 ? 9 : 0;
    for (int k = -1; k < last_neighbour; ++k) {
        ivec2 offset = k < 0 ? ivec2(0) : ivec2(k % 3 - 1, k / 3 - 1);
        ivec3 n = ivec3(clamp(texel.xy + offset, ivec2(0), ivec2(last)), texel.z);
        vec2 stored = texelFetch(u_visibility, ivec3(n.xy, first_layer + n.z), 0).rg;
        bool sees = texel_sees(n, stored, local, local_normal, own, own_surface, tolerance,
                               overhung);
        if (k < 0) {
            last_map_texel = n;
            last_map_distance = stored.r;
            if (sees) return 1.0;
            if (own - stored.r > 2.0 * tolerance.reach) return 0.0;
            // Whether what hides the receiver's own texel stands in front of its plane, not at
            // or behind it (the edge of the block it is the side of), for the 3x3 after it.
            overhung = blocker_height(world, normal) > u_epsilon;
        } else if (sees) {
            seen += 1.0;
        }
    }
    return seen / 9.0;
}
