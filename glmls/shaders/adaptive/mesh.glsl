// The adaptive mesh as its scan (adaptive/scan.comp.glsl) and its fold check
// (adaptive/folds.comp.glsl) read it (glmls.imaging.adaptive.scan uploads it), and the
// buffer of the tiles near folds they share.

#include "common/table.glsl"

#define HOT_SHIFT 3   // tiles of 8 x 8 pixels

// tables (common/table.glsl), read with adaptive_vertex and adaptive_triangle
layout(binding = BIND_ADAPTIVE_VERTICES) uniform sampler2D adaptive_vertices;
                              // per vertex: (output x, y, source x, y), pixels
layout(binding = BIND_ADAPTIVE_TRIANGLES) uniform usampler2D adaptive_triangles;
                              // per triangle in scan order: three vertex ids, its leaf

vec4 adaptive_vertex(uint id) {
    return TABLE_FETCH(adaptive_vertices, id);
}

uvec4 adaptive_triangle(int t) {
    return TABLE_FETCH(adaptive_triangles, t);
}
layout(std430, binding = BIND_ADAPTIVE_HOT) buffer AdaptiveHot {
    uint adaptive_hot_count;   // the scan's listed triangles
    uint adaptive_reversed;    // the fold check's reversed triangles (0 before it)
    uint adaptive_hot_pad[2];
    uint adaptive_hot[];       // the scan's list (u_hot_bits of room), then the tiles' bits
};

uniform ivec2 u_target_size;  // W, H in pixels
uniform int u_hot_bits;       // where the tiles' bits start in adaptive_hot
uniform int u_hot_words;      // uints per row of tiles

uniform float u_orientation;  // +1 or -1: the sign of a triangle that keeps the mesh's

// Is the triangle (a, b, c), twice its signed area ``area`` (edge(a, b, c)), not of the mesh's
// orientation (u_orientation: +1 where f keeps it, -1 for a mirror), or nearly degenerate:
// twice its area within 1e-5 of its longest side squared (room for float32's rounding, which
// the scan's own area then cannot turn over)? glmls.imaging.adaptive.folds.check_folds is the
// float64 reference.
bool adaptive_turned(vec2 a, vec2 b, vec2 c, float area) {
    vec2 ab = b - a;
    vec2 bc = c - b;
    vec2 ca = a - c;
    float longest = max(max(dot(ab, ab), dot(bc, bc)), dot(ca, ca));
    return u_orientation * area <= 1.0e-5 * longest;
}
