// What the visibility map keeps per texel, by MIN blending: the exact nearest distance, and
// that distance rounded down to 11 mantissa bits with the number of the surface (a smooth
// patch of triangles, see Solver._surfaces) in the 12 bits below. Positive floats order as
// their bits do, so the minimum of the second channel carries the nearest surface's number.
vec2 stored_distance(float distance, float surface) {
    uint bits = (floatBitsToUint(distance) & 0xFFFFF000u) | (uint(surface) & 0xFFFu);
    return vec2(distance, uintBitsToFloat(bits));
}
