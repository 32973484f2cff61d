"""Luxel against a reference (a Cycles bake): errors per texel and per object, perceptual and
FLIP differences of rendered views, lightmap snapshots over time, and the report with its
speed-against-error plot. Blender-free, like the rest of native/."""
