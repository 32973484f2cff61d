// The z of the cross product of two vectors in a plane: twice the signed area they span.
float cross2(vec2 a, vec2 b) { return a.x * b.y - a.y * b.x; }
