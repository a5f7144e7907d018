// Scan conversion of the deformed mesh in a compute shader: the rasterizer's job for the
// "quads" method, without its per-triangle setup cost (llvmpipe spends ~0.25 us per triangle,
// 0.5 s for the 2 million triangles of a 1024^2 image at grid 1).
//
// One invocation per mesh cell: the cell's two triangles (00, 10, 11) and (00, 11, 01) are
// tested at every pixel centre of their bounding box, and each covered pixel records the
// triangle's key with atomicMax. A key is 2^31 - the bit fields, most significant first,
// cell row | cell column | triangle (0, 1) | [WARP_CELLS_SOURCE: the nearest source pixel's
// row and column inside the cell, u_sub_bits each], at the shifts glmls.imaging.quads's
// key_layout chose (31 bits at most, so a key is never 0, "none"). The largest key, the
// smallest bit fields, wins whatever order the invocations run in: where cells fold, the
// FIRST cell in row-major scan order of the source (smaller row, then column; triangle 0
// before 1) shows, the paper's rule (a pixel once marked keeps its colour), which the GL
// rasterizer path gets by drawing the cells in reverse order (glmls.imaging.raster). (Bit
// fields, not a row-major index, so that the fills decode them without an integer division
// per pixel.)
//
// The fills: warp/cells.frag.glsl interpolates the winning triangle (linear, source points);
// with WARP_CELLS_SOURCE (nearest) the key holds the source pixel and
// warp/cells_nearest.frag.glsl copies it; with WARP_CELLS_FUSED as well (RGBA8 source and
// target) this shader writes the colours itself (warp/cells_packed.glsl) and
// warp/cells_fixup.comp.glsl corrects the pixels that more than one triangle reached.
//
// WARP_CELLS_FAST (with FUSED): the optimistic pass for a mesh that may be an embedding:
// no keys, no atomics, each covered pixel just gets its colour. A cell that is not strictly
// positively oriented counts and lists itself (warp_check_folded, warp/cells_hot.glsl) and
// draws nothing; warp/cells_check.comp.glsl then marks the tiles of the target that the
// listed cells' pixels (and one more on each side, against rounding) reach hot. With the boundary test of warp/cells_check.comp.glsl this decides
// whether and where the keyed pass must redo the picture: where the boundary is a simple
// curve, WARP_CELLS_HOT (with FUSED, after the fast pass) redraws with keys only the cells
// of the listed blocks whose pixels reach a hot tile; otherwise the keyed pass redraws every
// cell. Why that is exact: a pixel covered twice then lies in a cell not positive (see
// warp/cells_check.comp.glsl), so every cell covering it reaches a hot tile and is redrawn
// with its key; a pixel of any other cell is covered once, and the fast pass wrote its
// colour.
//
// The mesh is a glmls.core.mesh.MeshLattice (corners), possibly with a margin past the image
// (border modes): cells and source pixels are the lattice's own, the source pixel of lattice
// pixel p is p + u_lattice_offset, read by the border rule (common/border.glsl). Target
// pixels are the output frame's (warp/frame.glsl).
//
// A cell too large for one invocation on a driver that caps its loops (llvmpipe) is walked
// in pieces, tiles of its pixel box, by more invocations (common/pieces.glsl).
//
// Coverage is OpenGL's: pixel centres strictly inside, and on an edge only for one of the two
// triangles that share it (a top-left style tie rule). Each edge function is computed from
// the edge's endpoints in mesh-index order, with `precise`, so the two triangles on either
// side of an edge see exactly opposite values and no pixel is lost or drawn twice on a seam.
layout(local_size_x = LOCAL_SIZE) in;

#ifndef WARP_CELLS_HOT
#define WARP_CELLS_HOT 0
#endif

#include "warp/cells_packed.glsl"
#include "warp/frame.glsl"
#include "common/lattice.glsl"
#include "common/pieces.glsl"

layout(std430, binding = BIND_WINNER) buffer WarpWinner {
    uint warp_winner[];  // per target pixel, row-major: the shown triangle's key, 0 = none
};

uniform ivec2 u_target_size;  // W, H in pixels
uniform ivec2 u_mesh_dims;    // vertices per row, rows (of this band)
uniform int u_first_row;      // mesh row of the band's first row (glmls.core.mesh bands)
uniform int u_offset;         // first cell of this dispatch
uniform int u_sub_bits;       // key layout, see above (shifts of the low end of each field)
uniform int u_col_shift;
uniform int u_row_shift;
uniform ivec2 u_source_size;  // W, H of the source image (the fused colours)

#include "warp/mesh_fetch.glsl"

#include "warp/cells_hot.glsl"

vec2 vertex_px(ivec2 ij) {
    return warp_output_point(warp_mesh_at(ij));
}

#include "warp/coverage.glsl"

void main() {
    int cells_x = u_mesh_dims.x - 1;
#if WARP_CELLS_HOT
    // one work group per listed block (warp/cells_hot.glsl), one invocation per cell of it
    uint k = dispatch_item() / uint(LOCAL_SIZE);
    if (k >= warp_check_data[WARP_CHECK_LISTED]) {
        return;
    }
    int block = int(warp_check_data[u_block_list + k]);
    int blocks_x = (cells_x + BLOCK - 1) / BLOCK;
    int by = block / blocks_x;
    int local = int(gl_LocalInvocationID.x);
    int cx = (block - by * blocks_x) * BLOCK + local % BLOCK;
    int cy = by * BLOCK + local / BLOCK;
    if (cx >= cells_x || cy >= u_mesh_dims.y - 1) {
        return;
    }
#else
    int cell = u_offset + int(dispatch_item());   // 2-D when indirect (warp/cells_check)
    if (cell >= cells_x * (u_mesh_dims.y - 1)) {
        return;
    }
    int cy = cell / cells_x;
    int cx = cell - cy * cells_x;
#endif
    ivec2 c00 = ivec2(cx, cy);   // in the band
    vec2 p00 = vertex_px(c00);
    vec2 p10 = vertex_px(c00 + ivec2(1, 0));
    vec2 p01 = vertex_px(c00 + ivec2(0, 1));
    vec2 p11 = vertex_px(c00 + 1);

    // Orientation of each triangle; degenerate ones cover nothing (as in OpenGL).
    float s0 = sign(edge(p00, p10, p11));
    float s1 = sign(edge(p00, p11, p01));
#if WARP_CELLS_FAST
    if (!(s0 > 0.0 && s1 > 0.0)) {
        // folded or degenerate: listed, the keyed pass redraws the cells near it (the least
        // code here: this branch slows the scan of meshes that never take it)
        if (scan_first_piece()) {
            uint k = atomicAdd(warp_check_folded, 1u);
            if (k < uint(u_folded_capacity)) {
                warp_check_data[u_folded_list + int(k)] = uint(cy * cells_x + cx);
            }
        }
        return;
    }
    // both 1 from here: constants, the compiler drops the orientation's products per pixel
    s0 = 1.0;
    s1 = 1.0;
#endif
    if ((s0 == 0.0 && s1 == 0.0) || !within_pixels(vec4(p00, p10), vec4(p01, p11))) {
        return;
    }
    vec2 lo = min(min(p00, p10), min(p01, p11));
    vec2 hi = max(max(p00, p10), max(p01, p11));
    ivec2 first = max(ivec2(ceil(lo)), ivec2(0));
    ivec2 last = min(ivec2(floor(hi)), u_target_size - 1);
    if (!scan_piece(first, last)) {
        return;   // a large cell's piece it does not have (common/pieces.glsl)
    }
#if WARP_CELLS_HOT
    if (any(greaterThan(first, last)) || !warp_reaches_hot(first, last)) {
        return;   // no pixel, or drawn by the fast pass and covered by no other cell
    }
    atomicAdd(warp_check_redrawn, 1u);   // (each piece of a large cell counts)
#endif
    int row = cy + u_first_row;
    // 2^31 - the fields: the first triangle in scan order has the largest key
    uint id0 = 0x80000000u - (uint(row) << u_row_shift | uint(cx) << u_col_shift);
    uint id1 = id0 - (1u << (2 * u_sub_bits));   // triangle 1's key
#if WARP_CELLS_SOURCE
    // the cell's source pixels and the inverse areas of its triangles (barycentrics)
    ivec2 cell_lo = ivec2(cx, row) * u_grid;
    ivec2 cell_hi = min(cell_lo + u_grid - 1, u_lattice_size - 1);
    vec2 s00 = lattice_corner(ivec2(cx, row));
    vec2 size = lattice_corner(ivec2(cx, row) + 1) - s00;
    float inv0 = 1.0 / edge(p00, p10, p11);
    float inv1 = 1.0 / edge(p00, p11, p01);
#endif
    // A convex quad (both diagonals split it into triangles of one orientation: no fold)
    // covers, on each pixel row, a span between its outer edges: only the pixels of that
    // span (widened by SPAN_MARGIN against rounding) are tested, about 2/3 of the box at
    // grid 4. Other quads test their whole bounding box.
    float s2 = sign(edge(p10, p11, p01));
    float s3 = sign(edge(p10, p01, p00));
    bool convex = s0 != 0.0 && s0 == s1 && s0 == s2 && s0 == s3;
    // one pixel per step (warp/coverage.glsl's RowWalk)
    RowBounds bounds = row_bounds(p00, p10, p11, p01, s0, convex);
    RowWalk walk = row_walk(bounds, first, last);
#if WARP_CELLS_FAST
    // each edge's tie rule along its triangle's boundary (warp/coverage.glsl)
    bool tie_a = edge_tie(p10 - p00);
    bool tie_b = edge_tie(p11 - p10);
    bool tie_c = edge_tie(p01 - p11);
    bool tie_e = edge_tie(p00 - p01);
    bool tie_d = edge_tie(p11 - p00);
#endif
    while (row_walk_next(walk, bounds, first, last)) {
        bool in_row = walk.in_row;
        int column = walk.x;
        int y = walk.y;
        vec2 p = vec2(column, y);
#if WARP_CELLS_FAST
        // Both triangles positive (s0 = s1 = 1): the diagonal tells which one may cover p,
        // then that one's two other edges, each from its end points in mesh-index order as
        // below (the same values): two edge functions fewer than testing both triangles.
        float e_d = edge(p00, p11, p);   // the diagonal 00 -> 11
        bool upper = covers_by(e_d, tie_d);   // triangle 1's side
        // triangle 1: 01 -> 11 (e_c) and 00 -> 01 (e_e), both run backwards along its
        // boundary; triangle 0: 00 -> 10 (e_a) and 10 -> 11 (e_b)
        float e_1 = edge(upper ? p01 : p00, upper ? p11 : p10, p);   // e_c or e_a
        float e_2 = edge(upper ? p00 : p10, upper ? p01 : p11, p);   // e_e or e_b
        float flip = upper ? -1.0 : 1.0;
        bool inside = covers_by(flip * e_1, upper ? tie_c : tie_a) &&
                      covers_by(flip * e_2, upper ? tie_e : tie_b);
        uint id = inside ? (upper ? id1 : id0) : 0u;
#if WARP_CELLS_SOURCE
        vec2 t = upper ? vec2(-e_2 * inv1, 1.0 + e_1 * inv1) : vec2(1.0 - e_2 * inv0, e_1 * inv0);
#endif
#else
        // the five edges, in mesh-index order (00 < 10 < 01 < 11)
        float e_a = edge(p00, p10, p);   // 00 -> 10
        float e_b = edge(p10, p11, p);   // 10 -> 11
        float e_d = edge(p00, p11, p);   // the diagonal 00 -> 11
        float e_c = edge(p01, p11, p);   // 01 -> 11
        float e_e = edge(p00, p01, p);   // 00 -> 01
        uint id = 0u;
#if WARP_CELLS_SOURCE
        vec2 t = vec2(0.0);   // where in the cell's source rectangle, 0..1 (barycentric)
#endif
        // triangle 1: 00 -> 11 -> 01 -> 00 (tested first: triangle 0 comes first, it wins)
        if (s1 != 0.0 && covers(s1 * e_d, s1 * (p11 - p00)) &&
            covers(-s1 * e_c, s1 * (p01 - p11)) && covers(-s1 * e_e, s1 * (p00 - p01))) {
            id = id1;
#if WARP_CELLS_SOURCE
            t = vec2(-e_e * inv1, 1.0 + e_c * inv1);
#endif
        }
        // triangle 0: 00 -> 10 -> 11 -> 00 (where the cell folds onto itself, it wins)
        if (s0 != 0.0 && covers(s0 * e_a, s0 * (p10 - p00)) &&
            covers(s0 * e_b, s0 * (p11 - p10)) && covers(-s0 * e_d, s0 * (p00 - p11))) {
            id = id0;
#if WARP_CELLS_SOURCE
            t = vec2(1.0 - e_b * inv0, e_a * inv0);
#endif
        }
#endif
        id = in_row ? id : 0u;
        // Branch-free from here: llvmpipe runs buffer accesses under a divergent branch
        // lane by lane with mask tests, about twice the cost. An uncovered pixel (id 0)
        // changes nothing: atomicMax with 0, its colour stored out of range.
#if WARP_CELLS_SOURCE
        // nearest: the source pixel containing the point, clamped to the cell
        ivec2 sp = clamp(ivec2(floor(s00 + t * size + 0.5)), cell_lo, cell_hi) - cell_lo;
#if !WARP_CELLS_FAST
        id -= id != 0u ? uint(sp.y << u_sub_bits | sp.x) : 0u;   // the fast pass has no keys
#endif
#endif
        int i = y * u_target_size.x + column;
#if !WARP_CELLS_FAST
        uint before = atomicMax(warp_winner[i], id);
#endif
#if WARP_CELLS_FUSED
        // Every triangle writes its colour, in any order; with keys, one that finds the
        // pixel taken lists it for warp/cells_fixup.comp.glsl, which writes the winner's.
        ivec2 s = lattice_source_pixel(cell_lo + sp, u_source_size);
        warp_store(id != 0u ? ivec2(column, y) : ivec2(-1), warp_source_texel(s));
#endif
#if WARP_CELLS_FUSED && !WARP_CELLS_FAST
        if (before != 0u && id != 0u) {
            uint k = atomicAdd(warp_fixup_count, 1u);
            if (k < uint(u_fixup_capacity)) {
                warp_fixups[k] = uint(i);
            }
            warp_fixup_listed(k, uint(u_target_size.x * u_target_size.y));
        }
#endif
    }
}
