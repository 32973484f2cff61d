#version 410
// Receiver update for a batch of shooting patches, gathered one after another per texel in
// one pass: every receiving texel visible from a shooter gains irradiance pi * L * F, with F
// the exact point-to-polygon form factor (Lambert's formula) of the shooter's quad clipped to
// the receiver's horizon: bounded however close they are; summed over the quad's cells, each
// at its own radiance L (radiance_form_factor()). Each shooter's visibility map is the six
// layers from 6 x its index. The share of a shooter's light its glossy layers reflect leaves
// in a lobe about a direction (lobes.py), each cell's its own, the rest as from a diffuse
// surface.
#define VIEW_PER_SHOOTER
#include "projection.glsl"
#include "visibility_test.glsl"
#include "receiver_common.glsl"

// MOST_SHOOTERS, defined where the program is made (preprocess.create_programs), is the
// bake's batch size (memory.receiver_batch).
uniform int u_shooter_count;   // this pass's, up to MOST_SHOOTERS
uniform vec3 u_quads[4 * MOST_SHOOTERS];  // each shooter's quad corners, world space,
                                          // counter-clockwise about the shooter's normal
uniform vec3 u_centres[MOST_SHOOTERS];
// SHOOTER_CELLS (defined where the program is made) x as many cells of each quad, row by
// row from its first corner along its first edge: the unshot radiance of its texels,
// leaving the front face (shooters are one-sided: a two-sided emitter shoots from a
// mirrored copy).
uniform vec3 u_cell_radiances[SHOOTER_CELLS * SHOOTER_CELLS * MOST_SHOOTERS];
uniform int u_emits[MOST_SHOOTERS];       // 1: the shooter shoots emission, whose shadows
                                          // are sharp: receivers take visibility over their
                                          // texel's square (visible_over_texel); a reflected
                                          // shot's soft shadows at their sample point
uniform int u_any_emits;                  // 1: some shooter of the pass emits
uniform vec4 u_surface_extents[MOST_SHOOTERS];  // u min, u max, v min, v max of the shooter's
                                                // surface along its frame's tangent and
                                                // bitangent, from its centre
uniform vec2 u_lobe_shapes[MOST_SHOOTERS];   // each shooter's glossy lobe's GGX alpha and
                                             // Fresnel F0 (lobes.Lobe)
uniform vec3 u_lobe_shares[MOST_SHOOTERS];      // the glossy share of the radiance it shoots
// Each cell's lobe: its axis (xyz) and scale (w): its shape (lobe_shape()) times the scale is
// its radiance over the mean.
uniform vec4 u_cell_lobes[SHOOTER_CELLS * SHOOTER_CELLS * MOST_SHOOTERS];
uniform vec3 u_eyes[MOST_SHOOTERS];       // where each shooter's map was drawn from
uniform mat3 u_frames[MOST_SHOOTERS];     // and its frame (columns t, b, n)
uniform float u_thin_gap;      // a gap under this share of a texel is thin

// The current shooter (select_shooter): its index and values.
int shooter;
vec3 shot_quad[4];
vec3 shot_centre;
vec4 shot_extent;
vec2 shot_lobe_shape;
vec3 shot_lobe_share;

// A batch of one is known here: the pass then compiles without the loop over shooters.
int shooter_count() { return MOST_SHOOTERS == 1 ? 1 : u_shooter_count; }

bool pass_takes_squares() { return u_any_emits != 0; }

// The shooters of the pass whose light can reach the drawn tile, a bit each
// (receiver_boxes.vert).
flat in int v_shooters;

bool select_shooter(int index) {
    // The tiles a batch of one draws all receive its shooter.
    if (MOST_SHOOTERS > 1 && (v_shooters & (1 << index)) == 0) return false;
    shooter = index;
    for (int i = 0; i < 4; ++i) shot_quad[i] = u_quads[4 * index + i];
    shot_centre = u_centres[index];
    shot_extent = u_surface_extents[index];
    shot_lobe_shape = u_lobe_shapes[index];
    shot_lobe_share = u_lobe_shares[index];
    u_eye = u_eyes[index];
    u_frame = u_frames[index];
    return true;
}

// Within this many quad diagonals of a shooter's centre a receiver gathers its cells one by
// one; farther, where the form factor hardly varies across the quad, each its share of it.
const float CELL_REACH = 2.0;
// And each cell in CELL_PARTS x CELL_PARTS parts, each at its own radiance (part_radiance())
// and along the way its own light travels: seen from close by, light and lobe vary across a
// cell.
const int CELL_PARTS = 2;

// The radiance of the part of 'cell' at 'offset' (each in -0.5..0.5 of the cell) from its
// middle: the cell's, sloped towards its neighbours' as the line through their middles,
// the slope limited to keep every part's light positive. A cell's parts lie evenly about
// its middle and send what it does; the side of a cell nearer a hot spot's peak lights
// what faces it more than the cell's mean would.
vec3 part_radiance(ivec2 cell, vec2 offset) {
    const int LAST = SHOOTER_CELLS - 1;
    int base = shooter * SHOOTER_CELLS * SHOOTER_CELLS;
    vec3 own = u_cell_radiances[base + cell.y * SHOOTER_CELLS + cell.x];
    ivec2 low = max(cell - 1, ivec2(0)), high = min(cell + 1, ivec2(LAST));
    vec3 across = (u_cell_radiances[base + cell.y * SHOOTER_CELLS + high.x]
                   - u_cell_radiances[base + cell.y * SHOOTER_CELLS + low.x])
        * (offset.x / float(max(high.x - low.x, 1)));
    vec3 along = (u_cell_radiances[base + high.y * SHOOTER_CELLS + cell.x]
                  - u_cell_radiances[base + low.y * SHOOTER_CELLS + cell.x])
        * (offset.y / float(max(high.y - low.y, 1)));
    vec3 slope = abs(across) + abs(along);
    vec3 limit = min(vec3(1.0), own / max(slope, vec3(1e-30)));
    return own + limit * (across + along);
}

// One edge's term in Lambert's formula: the edge from a to b, relative to the receiver.
vec3 edge_term(vec3 a, vec3 b) {
    float la = length(a), lb = length(b);
    if (la < 1e-9 || lb < 1e-9) return vec3(0.0);
    a /= la; b /= lb;
    vec3 g = cross(a, b);
    float s = length(g);
    if (s < 1e-12) return vec3(0.0);
    return atan(s, dot(a, b)) * g / s;
}

// The vector form factor of 'polygon' at 'p' (Lambert's formula, the polygon clipped to the
// horizon of 'n'): the form factor is minus its component along 'n', and it points the way
// the polygon's light travels to p, its directions weighted by the solid angle they span.
// The clipped outline is summed edge by edge as it is found, each exit below the horizon
// joined along it to the next entry, without a list of its corners: llvmpipe runs indexed
// local arrays many times slower.
vec3 form_factor_vector(vec3 polygon[4], vec3 p, vec3 n) {
    vec3 sum = vec3(0.0);
    vec3 exit_point = vec3(0.0), first_entry = vec3(0.0);
    bool exited = false, entered_first = false;
    for (int i = 0; i < 4; ++i) {
        vec3 a = polygon[i] - p, b = polygon[(i + 1) % 4] - p;
        float da = dot(a, n), db = dot(b, n);
        bool a_above = da >= 0.0, b_above = db >= 0.0;
        if (a_above && b_above) {
            sum += edge_term(a, b);
        } else if (a_above || b_above) {
            vec3 crossing = a + (b - a) * (da / (da - db));
            if (a_above) {
                sum += edge_term(a, crossing);
                exit_point = crossing;
                exited = true;
            } else {
                sum += edge_term(crossing, b);
                if (exited) sum += edge_term(exit_point, crossing);
                else { first_entry = crossing; entered_first = true; }
                exited = false;
            }
        }
    }
    if (exited && entered_first) sum += edge_term(exit_point, first_entry);
    return sum / (2.0 * PI);
}

vec3 quad_point(float s, float t) {
    return mix(mix(shot_quad[0], shot_quad[1], s), mix(shot_quad[3], shot_quad[2], s), t);
}

// Fresnel's reflectance at 'cosine' of a dielectric reflecting 'normal_reflectance' at normal
// incidence (lobes.dielectric_fresnel()).
float dielectric_fresnel(float cosine, float normal_reflectance) {
    if (normal_reflectance >= 1.0) return 1.0;
    float root = sqrt(normal_reflectance);
    float eta = (1.0 + root) / (1.0 - root);
    float g = sqrt(eta * eta - 1.0 + cosine * cosine);
    float outer = (g - cosine) / (g + cosine);
    float inner = (cosine * (g + cosine) - 1.0) / (cosine * (g - cosine) + 1.0);
    return 0.5 * outer * outer * (1.0 + inner * inner);
}

// The lobe about 'axis' towards 'travel', before its scale: GGX's D(h) G1(travel)
// F(h . l) / cos for light from l, the axis's mirror (lobes.shape()).
float lobe_shape(vec3 axis, vec3 travel) {
    vec3 n = u_frame[2];
    float cos_out = dot(travel, n);
    if (cos_out <= 0.0) return 0.0;
    vec3 toward_light = 2.0 * dot(axis, n) * n - axis;
    vec3 half_vector = normalize(travel + toward_light);
    float alpha2 = shot_lobe_shape.x * shot_lobe_shape.x;
    float cos_half = clamp(dot(half_vector, n), 0.0, 1.0);
    float spread = cos_half * cos_half * (alpha2 - 1.0) + 1.0;
    float distribution = alpha2 / (PI * spread * spread);
    cos_out = max(cos_out, 1e-6);
    float masking = 2.0 / (1.0 + sqrt(1.0 + alpha2 * (1.0 - cos_out * cos_out)
                                                / (cos_out * cos_out)));
    float fresnel = dielectric_fresnel(clamp(dot(half_vector, toward_light), 0.0, 1.0),
                                       shot_lobe_shape.y);
    return distribution * masking * fresnel / cos_out;
}

// What the shooter's 'cell' sends along 'travel' over what a diffuse cell of its radiance
// would: its glossy share in its lobe (lobes.cell_lobes), the rest evenly.
vec3 lobe_factor(int cell, vec3 travel) {
#if GLOSSY_LOBES
    vec4 lobe = u_cell_lobes[shooter * SHOOTER_CELLS * SHOOTER_CELLS + cell];
    float radiance = lobe.w * lobe_shape(lobe.xyz, travel);
    return 1.0 + shot_lobe_share * (radiance - 1.0);
#else
    return vec3(1.0);
#endif
}

// Beyond this many quad diagonals of a shooter's centre, a receiver whose horizon the quad
// lies wholly above takes each cell's light from the cell's middle (point_form_factor()):
// there it is within 1.4 % of Lambert's formula for the cell, and the formula's polygon
// clipping, most of a receiver's time on llvmpipe, is spent only nearer.
const float POINT_REACH = 4.0;

// The shooter's radiance times the form factor towards 'p' as the sum of its cells'
// point-to-point form factors from their middles, each at its own radiance and lobe.
vec3 point_form_factor(vec3 p, vec3 n, int cells) {
    const int CELLS = SHOOTER_CELLS * SHOOTER_CELLS;
    float cell_area = 0.5 * length(cross(shot_quad[2] - shot_quad[0],
                                         shot_quad[3] - shot_quad[1])) / float(CELLS);
    vec3 sum = vec3(0.0);
    for (int k = 0; k < cells; ++k) {
        vec2 middle = (vec2(k % SHOOTER_CELLS, k / SHOOTER_CELLS) + 0.5) / float(SHOOTER_CELLS);
        vec3 travel = p - quad_point(middle.x, middle.y);
        float squared = dot(travel, travel);
        float form_factor = max(dot(travel, u_frame[2]), 0.0) * max(-dot(travel, n), 0.0)
            * cell_area / (PI * squared * squared);
        sum += u_cell_radiances[shooter * CELLS + k]
            * lobe_factor(k, travel * inversesqrt(squared)) * form_factor;
    }
    return sum;
}

// Whether the whole quad lies above the horizon of a receiver at 'p' facing 'n'.
bool quad_above_horizon(vec3 p, vec3 n) {
    for (int i = 0; i < 4; ++i) {
        if (dot(shot_quad[i] - p, n) <= 0.0) return false;
    }
    return true;
}

// The shooter's radiance times the form factor and its lobe's factor towards 'p', summed
// over its cells, each at its own radiance and with its own lobe. Far off, from the cells'
// middles (point_form_factor()). Near the shooter each part
// of a cell takes its own form factor and radiance, and the cell's lobe along the way the
// part's light travels to p: a hot spot in the block's middle lights what faces it more
// than the block's mean would, and a wall standing on a glossy floor gets most of its light
// from the floor nearest, along directions the cells' middles do not send in. Farther, the
// quad's form factor is shared among its cells, each along the way from its middle. One
// call site of form_factor_vector().
vec3 radiance_form_factor(vec3 p, vec3 n) {
    const int CELLS = SHOOTER_CELLS * SHOOTER_CELLS;
    const int PARTS = SHOOTER_CELLS * CELL_PARTS;   // along each side of the quad
    float diagonal = length(shot_quad[2] - shot_quad[0]);
    float from_centre = distance(p, shot_centre);
    bool far = from_centre > POINT_REACH * diagonal && quad_above_horizon(p, n);
    vec3 sum = point_form_factor(p, n, far ? CELLS : 0);
    bool near = from_centre < CELL_REACH * diagonal;
    int polygons = far ? 0 : near ? PARTS * PARTS : 1;
    float side = near ? 1.0 / float(PARTS) : 1.0;   // in the quad's parameters
    for (int j = 0; j < polygons; ++j) {
        ivec2 at = ivec2(j % PARTS, j / PARTS);
        vec2 low = vec2(at) * side;
        int own = (at.y / CELL_PARTS) * SHOOTER_CELLS + at.x / CELL_PARTS;   // its cell
        vec3 polygon[4] = vec3[4](quad_point(low.x, low.y), quad_point(low.x + side, low.y),
                                  quad_point(low.x + side, low.y + side),
                                  quad_point(low.x, low.y + side));
        vec3 vector = form_factor_vector(polygon, p, n);
        // Seen from its front, a polygon winds clockwise: the vector points away from n. A
        // point behind the quad sees its back, which emits nothing. The quad of a shooter
        // on a curved chart is a plane through the chart, a few degrees off the shooter's
        // frame: a texel on the surface's other side (an emitter's back-face copy, right
        // behind it) can lie above the frame's plane yet behind the quad, and at a
        // millimetre from it got almost all of it.
        float form_factor = clamp(-dot(n, vector), 0.0, 1.0);
        if (form_factor <= 0.0) continue;
        if (near) {
            ivec2 cell = at / CELL_PARTS;
            vec2 offset = (vec2(at - cell * CELL_PARTS) + 0.5) / float(CELL_PARTS) - 0.5;
            sum += part_radiance(cell, offset) * lobe_factor(own, normalize(vector))
                * form_factor;
            continue;
        }
        // Farther, the quad's form factor shared among its cells as their point-to-point
        // form factors from their middles: the cell nearest the receiver, which its light
        // brightened most (a lamp's hot spot on the wall beside it), takes the most. Where
        // every middle lies behind the receiver's horizon (the quad's edge above it lights
        // it), each cell alike.
        vec3 weighted = vec3(0.0), even = vec3(0.0);
        float weights = 0.0;
        for (int k = 0; k < CELLS; ++k) {
            vec2 middle = (vec2(k % SHOOTER_CELLS, k / SHOOTER_CELLS) + 0.5)
                / float(SHOOTER_CELLS);
            vec3 travel = p - quad_point(middle.x, middle.y);
            float squared = dot(travel, travel);
            float weight = max(dot(travel, u_frame[2]), 0.0) * max(-dot(travel, n), 0.0)
                / (squared * squared);
            vec3 light = u_cell_radiances[shooter * CELLS + k]
                * lobe_factor(k, travel * inversesqrt(squared));
            weighted += light * weight;
            even += light;
            weights += weight;
        }
        sum += form_factor * (weights > 0.0 ? weighted / weights : even / float(CELLS));
    }
    return sum;
}

#if SQUARE_RECEIVERS
// A receiver COARSER times as coarse as its shooter (receivers.COARSER), within SQUARE_REACH
// of its sides of it (beyond the shooter's half diagonal), takes the shooter's view of its
// square (receiver_form_factor()). Only the tiles that hold such receivers are drawn with
// this variant: on llvmpipe its code cost every texel a fifth more, taken or not.
const float SQUARE_REACH = 4.0;

// What the shooter's parts send into the receiver's square of side 'side' around 'p' (normal
// 'n'), as the form factor times radiance that radiance_form_factor() returns: each part's
// exact form factor (Lambert's formula from the part's middle) of the square, times the
// part's area over the square's. From a part the squares of all receivers share one
// hemisphere, so what a shot delivers to them sums to at most its power; a big texel's
// form factor from its sample point alone, times its area, took up to 1.2 times the shot
// from a corner's neighbour (a level at 0.5 texels per metre, where the unshot power then
// grew without end) and a tenth of it from a lamp a texel's side above it.
vec3 square_form_factor(vec3 p, vec3 n, float side) {
    const int PARTS = SHOOTER_CELLS * CELL_PARTS;   // along each side of the quad
    vec3 tangent = tangent_of(n);
    vec3 bitangent = cross(n, tangent);
    vec3 half_t = 0.5 * side * tangent, half_b = 0.5 * side * bitangent;
    vec3 square[4] = vec3[4](p - half_t - half_b, p + half_t - half_b, p + half_t + half_b,
                             p - half_t + half_b);
    vec3 shooter_normal = u_frame[2];
    vec3 sum = vec3(0.0);
    for (int j = 0; j < PARTS * PARTS; ++j) {
        ivec2 at = ivec2(j % PARTS, j / PARTS);
        vec2 middle = (vec2(at) + 0.5) / float(PARTS);
        vec3 from = quad_point(middle.x, middle.y);
        float form_factor = clamp(-dot(shooter_normal,
                                       form_factor_vector(square, from, shooter_normal)),
                                  0.0, 1.0);
        if (form_factor <= 0.0) continue;
        ivec2 cell = at / CELL_PARTS;
        vec2 offset = (vec2(at - cell * CELL_PARTS) + 0.5) / float(CELL_PARTS) - 0.5;
        sum += part_radiance(cell, offset)
            * lobe_factor(cell.y * SHOOTER_CELLS + cell.x, normalize(p - from)) * form_factor;
    }
    float shooter_area = 0.5 * length(cross(shot_quad[2] - shot_quad[0],
                                            shot_quad[3] - shot_quad[1]));
    return sum * (shooter_area / float(PARTS * PARTS)) / (side * side);
}
#endif

// The shooter's radiance times the form factor towards the receiver at 'p', whose sample
// point stands for a square of side 'side': the form factor at the sample point
// (radiance_form_factor()), or, where the receiver is much coarser than the shooter and near
// it, the shooter's view of its square (square_form_factor()), which the shooter's parts
// sample better than the receiver's point does: a lamp of 10 cm lit a floor of 2 m texels a
// metre from their sample points by a tenth of what it sent them, and a 5 cm ledge's light
// the texels beside it by a third more.
vec3 receiver_form_factor(vec3 p, vec3 n, float side) {
#if SQUARE_RECEIVERS
    float shooter_side = 0.5 * (length(shot_quad[1] - shot_quad[0])
                                + length(shot_quad[3] - shot_quad[0]));
    bool coarse = side > COARSER * shooter_side && distance(p, shot_centre)
        < SQUARE_REACH * side + 0.5 * length(shot_quad[2] - shot_quad[0]);
    return coarse ? square_form_factor(p, n, side) : radiance_form_factor(p, n);
#else
    return radiance_form_factor(p, n);
#endif
}

vec3 travel_direction(vec3 point) { return normalize(point - shot_centre); }

bool in_near_field(vec3 point, float texel_size) {
    float reach = 0.5 * length(shot_quad[2] - shot_quad[0]) + 2.0 * texel_size;
    return distance(point, shot_centre) < reach;
}

// A receiver facing the shooter across a gap under u_thin_gap of its texel, its sample
// point within a texel of the shooter's surface rectangle (a ceiling 0.1 mm over a lamp's
// back, or 1 cm over an office lamp at 25 cm texels, and beside it, where the gap's light
// leaks out). The solver gives it the gap's light in closed form, all its
// bounces at once (thin_gaps.close): shot by shot, at its sample point alone, a texel
// got all of a shooter over the point and none of one beside it, and the gap's light went
// back and forth for hundreds of shots.
bool across_thin_gap(vec3 from_shooter, float height, vec3 normal, float side) {
    vec2 at = vec2(dot(from_shooter, u_frame[0]), dot(from_shooter, u_frame[1]));
    return height < u_thin_gap * side && dot(normal, u_frame[2]) < -0.99
        && all(greaterThanEqual(at, shot_extent.xz - side))
        && all(lessThanEqual(at, shot_extent.yw + side));
}

vec3 irradiance_at(vec3 point, vec3 normal, float near_side, float square_side) {
    vec3 from_shooter = point - shot_centre;
    float height = dot(from_shooter, u_frame[2]);
    // Only what lies in front. The shooter's own plane gets nothing: Lambert's formula jumps
    // to 1 at a point inside a coplanar polygon, and rounding puts such points on either side.
    if (height <= u_epsilon || dot(normal, from_shooter) >= 0.0) return vec3(0.0);
    // Across a thin gap the solver gives the light (across_thin_gap()).
    if (near_side > 0.0 && across_thin_gap(from_shooter, height, normal, near_side)) return vec3(0.0);
    float visible = visible_over_texel(point, 6 * shooter, u_emits[shooter] != 0);
    if (visible <= 0.0) return vec3(0.0);
    return PI * receiver_form_factor(point, normal, square_side) * visible;
}
