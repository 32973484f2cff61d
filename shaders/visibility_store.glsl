// What the visibility map keeps per texel, by MIN blending: the exact nearest distance, and
// that distance rounded down to 10 mantissa bits with a bit set when the triangle faces away
// from the eye and, in the 12 bits below, the number of its surface (smooth_surfaces in
// geometry.py). Positive floats order as their bits do, so the minimum of the second channel
// carries the nearest surface's number; at a tie, a surface facing the eye wins over one
// facing away (the two faces of a sheet), then the lower number (emitters come first).
vec2 stored_distance(float distance, float surface, bool faces_away) {
    uint key = (uint(surface) & 0xFFFu) | (faces_away ? 0x1000u : 0u);
    uint bits = (floatBitsToUint(distance) & 0xFFFFE000u) | key;
    return vec2(distance, uintBitsToFloat(bits));
}

// Whether a triangle (corners relative to the eye, in a frame of the same handedness as the
// world's) shows the eye its back.
bool faces_away_from_eye(vec3 c0, vec3 c1, vec3 c2) {
    return dot(cross(c1 - c0, c2 - c0), c0) > 0.0;
}
