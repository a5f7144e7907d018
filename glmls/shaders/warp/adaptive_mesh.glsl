// The adaptive mesh as its scan (warp/adaptive.comp.glsl) and its fold check
// (warp/adaptive_folds.comp.glsl) read it (glmls.imaging.adaptive_scan uploads it), and the
// buffer of the tiles near folds they share.

#define HOT_SHIFT 3   // tiles of 8 x 8 pixels

layout(std430, binding = BIND_DEFORMED) readonly buffer AdaptiveVertices {
    vec4 adaptive_vertex[];   // (output x, y, source x, y), pixels
};
layout(std430, binding = BIND_POINTS) readonly buffer AdaptiveTriangles {
    uint adaptive_index[];    // per triangle in scan order: three vertex indices, its leaf
};
layout(std430, binding = BIND_ADAPTIVE_HOT) buffer AdaptiveHot {
    uint adaptive_hot_count;   // the scan's listed triangles
    uint adaptive_reversed;    // the fold check's reversed triangles (0 before it)
    uint adaptive_hot_pad[2];
    uint adaptive_hot[];       // the scan's list (u_hot_bits of room), then the tiles' bits
};

uniform ivec2 u_target_size;  // W, H in pixels
uniform int u_hot_bits;       // where the tiles' bits start in adaptive_hot
uniform int u_hot_words;      // uints per row of tiles
