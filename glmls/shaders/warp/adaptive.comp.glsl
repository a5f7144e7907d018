// Scan conversion of the adaptive mesh's triangles (glmls.imaging.adaptive) in a compute
// shader, as warp/cells.comp.glsl does for the regular mesh (the GL rasterizer's per-triangle
// setup costs ~0.25 us a triangle on llvmpipe).
//
// One invocation per triangle: every pixel centre of its bounding box row span that it
// covers records the key u_triangles - t with atomicMax, t its index in scan order (the
// leaves in row-major order of their top-left corners, each leaf's fan together), so the
// FIRST triangle in scan order shows wherever triangles overlap (fold-overs), whatever order
// the invocations run in. 0 is "none".
//
// Coverage is OpenGL's: pixel centres strictly inside, and on an edge for one of the two
// triangles sharing it (a top-left style tie rule). Each edge function is computed from the
// edge's end points in vertex-index order, with `precise`, so the two triangles on either
// side of an edge (of one fan, or of two leaves: their boundaries run through the same
// vertices) see exactly opposite values: no pixel of a seam is lost.
layout(local_size_x = LOCAL_SIZE) in;

#include "common/groups.glsl"

layout(std430, binding = BIND_DEFORMED) readonly buffer AdaptiveVertices {
    vec4 adaptive_vertex[];   // (output x, y, source x, y), pixels
};
layout(std430, binding = BIND_POINTS) readonly buffer AdaptiveTriangles {
    uint adaptive_index[];    // three vertex indices per triangle, in scan order
};
layout(std430, binding = BIND_WINNER) buffer AdaptiveWinner {
    uint adaptive_winner[];   // per target pixel, row-major: u_triangles - t, 0 = none
};

uniform ivec2 u_target_size;  // W, H in pixels
uniform int u_triangles;      // how many
uniform int u_offset;         // first triangle of this dispatch

#include "warp/coverage.glsl"

// Edge (i, j) at p, its end points taken in index order; d: its direction, i to j.
float ordered_edge(uint i, uint j, vec2 a, vec2 b, vec2 p) {
    return i < j ? edge(a, b, p) : -edge(b, a, p);
}

void main() {
    int t = u_offset + int(dispatch_item());
    if (t >= u_triangles) {
        return;
    }
    uint ia = adaptive_index[3 * t];
    uint ib = adaptive_index[3 * t + 1];
    uint ic = adaptive_index[3 * t + 2];
    vec2 a = adaptive_vertex[ia].xy;
    vec2 b = adaptive_vertex[ib].xy;
    vec2 c = adaptive_vertex[ic].xy;
    float s = sign(edge(a, b, c));
    if (s == 0.0) {
        return;   // degenerate: covers nothing, as in OpenGL
    }
    ivec2 first = max(ivec2(ceil(min(min(a, b), c))), ivec2(0));
    ivec2 last = min(ivec2(floor(max(max(a, b), c))), u_target_size - 1);
    uint key = uint(u_triangles - t);
    // the edges' directions along the triangle's counter-clockwise boundary
    vec2 dab = s * (b - a);
    vec2 dbc = s * (c - b);
    vec2 dca = s * (a - c);
    for (int y = first.y; y <= last.y; ++y) {
        float left = float(first.x);
        float right = float(last.x);
        span(a, b, s, float(y), left, right);
        span(b, c, s, float(y), left, right);
        span(c, a, s, float(y), left, right);
        int x_end = min(last.x, int(floor(right + SPAN_MARGIN)));
        for (int x = max(first.x, int(ceil(left - SPAN_MARGIN))); x <= x_end; ++x) {
            vec2 p = vec2(x, y);
            if (covers(s * ordered_edge(ia, ib, a, b, p), dab) &&
                covers(s * ordered_edge(ib, ic, b, c, p), dbc) &&
                covers(s * ordered_edge(ic, ia, c, a, p), dca)) {
                atomicMax(adaptive_winner[y * u_target_size.x + x], key);
            }
        }
    }
}
