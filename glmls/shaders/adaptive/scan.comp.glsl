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
// ADAPTIVE_FILL 1: the second pass, the same scan: each pixel whose winner is this triangle
// gets its source point, the triangle's linear interpolation refined on its leaf's quadratic
// patch (adaptive/patch.glsl), loaded once per triangle; adaptive/fill.frag.glsl then
// samples the source there. ADAPTIVE_FILL 2: the one pass of a mesh that is an embedding
// (glmls.imaging.adaptive.scan checks it: every triangle of one orientation and a boundary
// that turns once): each pixel is covered by exactly one triangle, which writes its source
// point, no keys. Pixels no triangle writes keep the buffer's "none" value. The pass counts
// the reversed (or nearly degenerate) triangles in adaptive_reversed, as the fold check
// does: where no leaf folds, the scan runs it before any check, and only if it finds one
// draws the mesh again by the checked passes (which write every pixel it wrote).
//
// ADAPTIVE_HOT 1 (with ADAPTIVE_FILL 2): the one pass of a mesh whose boundary turns once
// but some of whose triangles are reversed (it folds): a pixel covered twice is then covered
// by a reversed triangle, so only pixels in the tiles those reach ("hot", 8 x 8 px, from
// glmls.imaging.adaptive.scan) may need keys. A triangle that reaches a hot tile draws
// nothing and lists itself; ADAPTIVE_LIST 1 then runs the keyed passes (ADAPTIVE_FILL 0, 1)
// over the listed triangles only, their keys still their places in scan order.
//
// ADAPTIVE_COLOUR 1 (with ADAPTIVE_FILL 1 or 2): the pass samples the source at each point
// itself (warp/sample.glsl) and stores the colour in the RGBA8 target image, instead of
// writing the point for adaptive/fill.frag.glsl. ADAPTIVE_TEXELS 1 as well (nearest, an RGBA8
// source): source and target are bound as r32ui images and each texel is copied whole
// (warp/texels.glsl).
//
// A triangle too large for one invocation on a driver that caps its loops (llvmpipe) is
// walked in pieces, tiles of its pixel box, by more invocations (common/pieces.glsl).
//
// Coverage is OpenGL's: pixel centres strictly inside, and on an edge for one of the two
// triangles sharing it (a top-left style tie rule). Each edge function is computed from the
// edge's end points in vertex-index order, with `precise`, so the two triangles on either
// side of an edge (of one fan, or of two leaves: their boundaries run through the same
// vertices) see exactly opposite values: no pixel of a seam is lost.
layout(local_size_x = LOCAL_SIZE) in;

#ifndef ADAPTIVE_FILL
#define ADAPTIVE_FILL 0
#endif
#ifndef ADAPTIVE_COLOUR
#define ADAPTIVE_COLOUR 0
#endif
#ifndef ADAPTIVE_TEXELS
#define ADAPTIVE_TEXELS 0
#endif
#ifndef ADAPTIVE_HOT
#define ADAPTIVE_HOT 0
#endif
#ifndef ADAPTIVE_LIST
#define ADAPTIVE_LIST 0
#endif
#include "common/groups.glsl"
#include "common/pieces.glsl"
#include "adaptive/mesh.glsl"

layout(std430, binding = BIND_WINNER) buffer AdaptiveWinner {
    uint adaptive_winner[];   // per target pixel, row-major: u_triangles - t, 0 = none
};

uniform int u_triangles;      // how many
uniform int u_offset;         // first triangle of this dispatch

#if ADAPTIVE_HOT || ADAPTIVE_LIST
uniform int u_count;          // ADAPTIVE_LIST: how many triangles are listed

// Does the pixel box [first, last] reach a hot tile?
bool reaches_hot(ivec2 first, ivec2 last) {
    for (int ty = first.y >> HOT_SHIFT; ty <= last.y >> HOT_SHIFT; ++ty) {
        for (int tx = first.x >> HOT_SHIFT; tx <= last.x >> HOT_SHIFT; ++tx) {
            uint word = adaptive_hot[u_hot_bits + ty * u_hot_words + (tx >> 5)];
            if ((word & (1u << (tx & 31))) != 0u) {
                return true;
            }
        }
    }
    return false;
}
#endif

#if ADAPTIVE_FILL
#include "adaptive/patch.glsl"
#include "common/border.glsl"   // outside the #if: the loader includes each file once
#if ADAPTIVE_COLOUR && ADAPTIVE_TEXELS
// nearest from an RGBA8 source into the RGBA8 target: texels copied whole
#include "warp/texels.glsl"
uniform ivec2 u_source_size;  // W, H of the source image
#elif ADAPTIVE_COLOUR
#include "warp/sample.glsl"
layout(rgba8, binding = BIND_ADAPTIVE_TARGET) writeonly uniform image2D adaptive_target;
#else
layout(std430, binding = BIND_ADAPTIVE_POINTS) writeonly buffer AdaptivePoints {
    vec2 adaptive_point[];    // per target pixel, row-major: its source point
};
#endif

// Pixel i = (x, y) of the target gets source point s, or (shown false) nothing: the spare
// element past the last pixel, or a store outside the image, which has no effect.
void adaptive_write(int i, ivec2 pixel, vec2 s, bool shown) {
#if ADAPTIVE_COLOUR && ADAPTIVE_TEXELS
    // the source pixel containing s (warp/sample.glsl's nearest), by the border rule
    ivec2 p = border_pixel(ivec2(floor(s + 0.5)), u_source_size);
    warp_store(shown ? pixel : ivec2(-1), warp_source_texel(p));
#elif ADAPTIVE_COLOUR
    imageStore(adaptive_target, shown ? pixel : ivec2(-1), warp_sample(s));
#else
    adaptive_point[shown ? i : u_target_size.x * u_target_size.y] = s;
#endif
}
#endif

#define ROW_EDGES 3   // triangles: three edges bound the row spans
#include "warp/coverage.glsl"

// An edge's end points in vertex-index order (from, to) and the sign that turns the edge
// function from one to the other into that of a to b: chosen once per triangle, so that a
// pixel evaluates each edge once.
struct OrderedEdge {
    vec2 from;
    vec2 to;
    float sign;
};

OrderedEdge ordered_edge(uint i, uint j, vec2 a, vec2 b) {
    OrderedEdge e;
    e.from = i < j ? a : b;
    e.to = i < j ? b : a;
    e.sign = i < j ? 1.0 : -1.0;
    return e;
}

void main() {
#if ADAPTIVE_LIST
    int item = u_offset + int(dispatch_item());
    if (item >= u_count) {
        return;
    }
    int t = int(adaptive_hot[item]);
#else
    int t = u_offset + int(dispatch_item());
    if (t >= u_triangles) {
        return;
    }
#endif
    uvec4 ids = adaptive_triangle(t);   // its vertices, then its leaf
    uint ia = ids.x;
    uint ib = ids.y;
    uint ic = ids.z;
    vec4 va = adaptive_vertex(ia);
    vec4 vb = adaptive_vertex(ib);
    vec4 vc = adaptive_vertex(ic);
    vec2 a = va.xy;
    vec2 b = vb.xy;
    vec2 c = vc.xy;
    float area = edge(a, b, c);   // twice the signed area
    float s = sign(area);
    bool representable = within_pixels(vec4(a, b), vec4(c, c));
#if ADAPTIVE_FILL == 2 && !ADAPTIVE_HOT
    // the one pass counts the triangles the fold check would (adaptive/folds.comp.glsl):
    // run without it, where the mesh is most likely an embedding, none must be found
    if (representable && adaptive_turned(a, b, c, area) && scan_first_piece()) {
        atomicAdd(adaptive_reversed, 1u);
    }
#endif
    // degenerate: covers nothing, as in OpenGL; so does a vertex far past any image (or not
    // a number), which the conversions to pixels below could not represent
    if (s == 0.0 || !representable) {
        return;
    }
    ivec2 first = max(ivec2(ceil(min(min(a, b), c))), ivec2(0));
    ivec2 last = min(ivec2(floor(max(max(a, b), c))), u_target_size - 1);
    uint key = uint(u_triangles - t);
    // no pixel centre in its box (a quarter of W2's triangles, in its finest leaves): done
    // before the leaf's patch is read, six loads per triangle (W2's passes 0.95x)
    if (first.x > last.x || first.y > last.y) {
        return;
    }
#if ADAPTIVE_HOT
    // a triangle walked in pieces (common/pieces.glsl) is listed whole, by its first piece
    // (the loop over its hot tiles could be long): the keyed passes draw it
    if (scan_pieces(first, last) > 1 || reaches_hot(first, last)) {
        if (scan_first_piece()) {
            adaptive_hot[atomicAdd(adaptive_hot_count, 1u)] = uint(t);   // for the keyed passes
        }
        return;
    }
#endif
    if (!scan_piece(first, last)) {
        return;   // a large triangle's piece it does not have (common/pieces.glsl)
    }
#if ADAPTIVE_FILL
    LeafPatch leaf = load_patch(int(ids.w));
    // the linear guess in the leaf's centred coordinates (adaptive/patch.glsl), an affine
    // function of the pixel: w = w_a + guess (p - a), the barycentrics folded in
    mat2 to_barycentric = (1.0 / area) * mat2(c.y - a.y, a.y - b.y, a.x - c.x, b.x - a.x);
    mat2 guess = mat2(vb.zw - va.zw, vc.zw - va.zw) * to_barycentric;
    guess[0] /= leaf.box.zw;
    guess[1] /= leaf.box.zw;
    vec2 w_a = (va.zw - leaf.box.xy) / leaf.box.zw;
#endif
#if ADAPTIVE_FILL != 1
    // the edges' directions along the triangle's counter-clockwise boundary (the tie rule)
    vec2 dab = s * (b - a);
    vec2 dbc = s * (c - b);
    vec2 dca = s * (a - c);
    OrderedEdge eab = ordered_edge(ia, ib, a, b);
    OrderedEdge ebc = ordered_edge(ib, ic, b, c);
    OrderedEdge eca = ordered_edge(ic, ia, c, a);
#endif
    // one pixel per step (warp/coverage.glsl's RowWalk)
    RowBounds bounds = row_bounds(a, b, c, c, s, true);   // (d unused)
    RowWalk walk = row_walk(bounds, first, last);
    while (row_walk_next(walk, bounds, first, last)) {
        // Branch-free: llvmpipe runs buffer accesses under a divergent branch lane by
        // lane with mask tests, about twice the cost.
        bool in_row = walk.in_row;
        int column = walk.x;
        int y = walk.y;
        vec2 p = vec2(column, y);
        int i = y * u_target_size.x + column;
#if ADAPTIVE_FILL
        vec2 w = w_a + guess * (p - a);
#endif
#if ADAPTIVE_FILL == 1
        // the winner key names one triangle: no coverage test (in_row: this row's)
        bool shown = in_row && adaptive_winner[i] == key;
#else
        bool inside = in_row &&
                      covers(s * eab.sign * edge(eab.from, eab.to, p), dab) &&
                      covers(s * ebc.sign * edge(ebc.from, ebc.to, p), dbc) &&
                      covers(s * eca.sign * edge(eca.from, eca.to, p), dca);
#endif
#if ADAPTIVE_FILL == 1
        adaptive_write(i, ivec2(column, y), patch_inverse(leaf, p, w), shown);
#elif ADAPTIVE_FILL == 2
        adaptive_write(i, ivec2(column, y), patch_inverse(leaf, p, w), inside);
#elif ADAPTIVE_FILL == 0
        atomicMax(adaptive_winner[i], inside ? key : 0u);
#endif
    }
}
