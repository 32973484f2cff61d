// Receiver pass shared by the patch and light shaders: each defines irradiance_at(), the
// irradiance a point gets from the current shooter (0 where hidden or facing away), and the
// shooters the pass gathers from (a batch of patches, or one light), one after another.
// Every texel of a drawn tile writes what it gathered (zero where nothing) into its page's
// gathered maps; deliver.frag then adds it to the maps, scaled so that the pass delivers
// no more than its shooters sent (receivers.update).
uniform sampler2D u_position;
uniform sampler2D u_normal;
uniform sampler2D u_level;     // subdivision level of the texel


layout(location = 0) out vec4 out_irradiance;  // the irradiance the texel gathered
#if GLOSSY_LOBES   // where the scene's glossy layers leave in lobes (lobes.py)
layout(location = 1) out vec4 out_incoming;    // the directions it travelled in (xyz)
                                               // weighted by the irradiance each brought,
                                               // and its sum (w)
#endif



const float PI = 3.14159265358979;

float receiver_surface;   // the number of the texel's surface, for visible_from_eye()
// The texel's surface's normal at its sample point: its plane, against which visibility is
// tested, whatever normal the texel gathers at (a curved texel gathers at two).
vec3 receiver_normal;
// The receiving texel's square (its steps to the next texels on the page), over which a
// gather at its sample point takes visibility; zero where it gathers at several points
// (subdivided, or next to the shooter) or at a chart's border.
vec3 texel_across = vec3(0.0), texel_along = vec3(0.0);
// A texel's area within this share of its square's: its whole square is surface; and its
// steps to its neighbours within this sine of its plane: the square is flat.
const float COVERED = 0.02;
const float FLAT_SINE = 0.01;

// The texel's steps to the next texels on the page along its rows and columns (from a
// neighbour on its surface at either side), where its square is all surface: its area is
// the square's. Where it is not (a chart's border), points across the square lay off the
// surface (beside a lamp's pole, in the air) and saw what the surface does not.
bool steps_inside(ivec2 texel, vec4 position, vec3 normal, float surface, out vec3 across,
                  out vec3 along) {
    ivec2 size = textureSize(u_position, 0);
    vec3 steps[2];
    for (int axis = 0; axis < 2; ++axis) {
        steps[axis] = vec3(0.0);
        for (int side = 1; side >= -1; side -= 2) {
            ivec2 at = texel + (axis == 0 ? ivec2(side, 0) : ivec2(0, side));
            if (any(lessThan(at, ivec2(0))) || any(greaterThanEqual(at, size))) continue;
            vec4 next = texelFetch(u_position, at, 0);
            bool on_surface = next.w > 0.0
                && decode_surface(texelFetch(u_material, at, 0).a) == surface;
            if (on_surface && steps[axis] == vec3(0.0))
                steps[axis] = float(side) * (next.xyz - position.xyz);
        }
    }
    across = steps[0];
    along = steps[1];
    float square = length(cross(across, along));
    return square > 0.0 && abs(position.w - square) <= COVERED * square
        && abs(dot(across, normal)) <= FLAT_SINE * length(across)
        && abs(dot(along, normal)) <= FLAT_SINE * length(along);
}

// Four points of a texel's square on a rotated grid: a shadow edge along either of its sides
// passes them at four different places.
const vec2 ACROSS_TEXEL[4] = vec2[4](vec2(-0.125, -0.375), vec2(0.375, -0.125),
                                     vec2(0.125, 0.375), vec2(-0.375, 0.125));

// How much of the receiving texel around 'point' the eye sees (visible_from_eye): with
// 'over_square', the mean over ACROSS_TEXEL of its square (texel_across, texel_along), not
// its sample point's alone. Cycles' bake of a texel, and what the texel shows, is the mean
// over its surface: a sharp shadow's edge along a row of texels (a board's, a sill's under
// the sun) left the whole row in shadow, or the whole row lit, where it is partly lit.
// Points of the square see more than a hidden sample point only past a blocker more than
// a texel in front of it: a wall standing on the surface crosses the square, and the light
// on its one side must not reach the other. One loop and one call site of
// visible_from_eye(), for llvmpipe's sake.
float visible_over_texel(vec3 point, int first_layer, bool over_square) {
    vec3 normal = receiver_normal;
    int last = over_square && texel_across != vec3(0.0) ? 4 : 0;
    float near = max(length(texel_across), length(texel_along));
    float centre = 0.0, seen = 0.0;
    for (int k = -1; k < last; ++k) {
        vec2 at = k < 0 ? vec2(0.0) : ACROSS_TEXEL[k];
        vec3 at_point = point + at.x * texel_across + at.y * texel_along;
        float visible = visible_from_eye(at_point, normal, receiver_surface, first_layer);
        if (k < 0) {
            centre = visible;
            if (last > 0 && centre <= 0.0 && blocker_height(point, normal) <= near) return 0.0;
        } else {
            // Hidden by a surface within a texel of it: one the receiver meets (seen at a
            // grazing angle across a corner), not a shadow the sample point misses.
            if (visible < centre && blocker_height(at_point, normal) <= near) visible = centre;
            seen += visible;
        }
    }
    return last > 0 ? seen / float(last) : centre;
}

// The irradiance at 'point', which stands for a square of side 'square_side' of its texel;
// 'near_side' > 0: the point is the sample point of a texel of that side in the shooter's
// near field.
vec3 irradiance_at(vec3 point, vec3 normal, float near_side, float square_side);
// The direction the current shooter's light travels in to reach 'point'.
vec3 travel_direction(vec3 point);
// Whether the texel lies so close to the shooter that it gathers at its sample point only.
bool in_near_field(vec3 point, float texel_size);
// How many shooters the pass gathers from.
int shooter_count();
// Whether a shooter of the pass takes visibility over its receivers' squares
// (visible_over_texel): only then is each texel's square measured.
bool pass_takes_squares();
// Make shooter 'index' the current one for irradiance_at() and in_near_field(); false where
// the drawn tile cannot receive it (v_shooters).
bool select_shooter(int index);

void main() {
    ivec2 texel = ivec2(gl_FragCoord.xy);
    vec4 position = texelFetch(u_position, texel, 0);
    vec4 material = texelFetch(u_material, texel, 0);
    // Not a receiving texel: gathered_power.vert and deliver.frag skip it. A discard, not a
    // return: llvmpipe leaves the shader where every pixel of a group has discarded.
    if (!receives(position, material)) discard;
    receiver_surface = decode_surface(material.a);
    vec4 stored_normal = texelFetch(u_normal, texel, 0);
    vec3 normal = decode_normal(stored_normal.xy);
    receiver_normal = normal;
    // A texel's side on the surface: its area's root (less than a texel edge at chart borders).
    float side = sqrt(position.w);
    int level_split = 1 << decode_level(texelFetch(u_level, texel, 0).r);
    // A texel whose surface bends within it gathers at two normals, its mean normal turned
    // each way along the bend by acos(spread), so that their mean is the covered surface's
    // mean normal (texel_maps.glsl decode_bend): at its sample's normal it got the light of
    // one side of a cable for the whole of it. Next to the shooter it gathers at the sample's
    // normal: from the sample point other normals see a neighbouring part of a convex surface
    // (its shooter's quad a plane across the curve), which the surface does not. A flat
    // texel gathers at its normal.
    float spread = stored_normal.z;
    vec3 mean_normal = normal, turn = vec3(0.0);
    if (spread < 1.0) {   // decoded only where used: every texel runs this every shot
        vec3 bend_axis;
        decode_bend(normal, stored_normal.w, mean_normal, bend_axis);
        turn = sqrt(max(1.0 - spread * spread, 0.0)) * bend_axis;
    }
    vec3 across = vec3(0.0), along = vec3(0.0);
    bool inside = pass_takes_squares()
        && steps_inside(texel, position, normal, receiver_surface, across, along);
    vec3 tangent = tangent_of(normal);
    vec3 bitangent = cross(normal, tangent);
    vec3 irradiance = vec3(0.0);
    vec4 incoming = vec4(0.0);
    for (int shooter = 0; shooter < shooter_count(); ++shooter) {
        if (!select_shooter(shooter)) continue;
        // A subdivided texel gathers at split x split points spread over a square of its
        // area around its sample point (the part of the texel square its surface covers). Not
        // next to the shooter: a texel there re-shoots from its sample point, so light
        // gathered over the rest of its square (say in a gap behind an emitter) would leak
        // out from there. There it gathers at its sample point, or, across a thin gap with
        // that point over the shooter's surface, nothing here: the solver adds the gap's
        // light (receive_patch.frag, near_side).
        float near_side = in_near_field(position.xyz, side) ? side : 0.0;
        int split = near_side > 0.0 ? 1 : level_split;
        bool over_texel = inside && near_side == 0.0 && split == 1;
        texel_across = over_texel ? across : vec3(0.0);
        texel_along = over_texel ? along : vec3(0.0);
        int normals = spread < 1.0 && near_side == 0.0 ? 2 : 1;
        vec3 gathered = vec3(0.0);
        // One loop and one call site: a second inlined copy of irradiance_at() cost llvmpipe
        // as much again per fragment, even where no texel took its branch.
        for (int k = 0; k < split * split * normals; ++k) {
            int cell = k / normals;
            vec2 offset = (vec2(cell % split, cell / split) + 0.5) / float(split) - 0.5;
            vec3 gathering_normal = normals == 1 ? normal
                                  : spread * mean_normal + (k % 2 == 0 ? turn : -turn);
            gathered += irradiance_at(position.xyz + side * (offset.x * tangent
                                                             + offset.y * bitangent),
                                      gathering_normal, near_side, side / float(split));
        }
        gathered /= float(split * split * normals);
        irradiance += gathered;
#if GLOSSY_LOBES
        float brought = (gathered.r + gathered.g + gathered.b) / 3.0;
        // Not where nothing came: the direction from the shooter's own centre is NaN.
        if (brought > 0.0) incoming += brought * vec4(travel_direction(position.xyz), 1.0);
#endif
    }
    out_irradiance = vec4(irradiance, 0.0);
#if GLOSSY_LOBES
    out_incoming = incoming;
#endif
}
