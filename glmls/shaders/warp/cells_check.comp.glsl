// Is the deformed mesh an embedding (no pixel covered by two triangles)? The fast pass
// (warp/cells.comp.glsl with WARP_CELLS_FAST) writes colours without keys or atomics, counts
// the cells that are not strictly positively oriented and marks the tiles near them; this
// shader adds the test of the mesh's boundary and, unless both pass, sizes the clear and the
// keyed scan that redo the picture where needed (indirect dispatches: nothing is read back).
//
// Why that suffices: for a triangle mesh of a disc, the number of positive minus the number
// of negative triangles over a point (off the edges) is the winding number of the boundary's
// image around it; if the boundary is a simple closed curve that number is 0 or 1. So with
// all triangles positive no point is covered twice, and with some not positive, a point
// covered twice lies in one that is not (in its cell's bounding box, marked hot): the keyed
// scan then redraws only the cells reaching hot tiles (WARP_CELLS_HOT). A simple test of
// simplicity, sufficient not necessary: the boundary is star-shaped from the image c of the
// mesh's centre vertex, every edge turning strictly counter-clockwise about c (in the
// triangles' sense) and the whole going around exactly once (one crossing of the ray from c
// to +x). Strong deformations of the border fail it and the keyed scan redraws every cell.
//
//   WARP_CHECK_STAGE 1: one work group, after the fast pass: the boundary's edges, a share
//                       for each invocation, then (one invocation) the dispatch sizes of
//                       stages 2, 3 and 6 and the keyed scan's;
//                    2: the winner clear (dispatched with the sizes of stage 1);
//                    3: one invocation per block of cells where the boundary is simple and
//                       cells fold (none otherwise): list the blocks whose pixels reach a hot
//                       tile (warp/cells_hot.glsl), raising the keyed scan's work groups;
//                    6: one invocation per listed cell not strictly positive (WARP_CELLS_FAST):
//                       mark its tiles hot and its block (stage 3 reads all its vertices).
// Every stage after 1 is an indirect dispatch: a mesh that is an embedding runs none of them
// (on llvmpipe each dispatch that runs costs ~35-55 us, whatever its size: the boundary's
// test is stage 1's own for that reason, not a dispatch of its own).
layout(local_size_x = LOCAL_SIZE) in;

#include "warp/cells_packed.glsl"
#include "warp/frame.glsl"

layout(std430, binding = BIND_WINNER) writeonly buffer WarpWinner {
    uvec4 warp_winner4[];   // the keys, four per element
};

uniform ivec2 u_mesh_dims;    // vertices per row, rows (the whole mesh)
uniform ivec2 u_target_size;
uniform int u_offset;         // first item of this dispatch (stage 3)

#include "warp/mesh_fetch.glsl"

#include "warp/cells_hot.glsl"

vec2 vertex_px(ivec2 ij) {
    return warp_output_point(warp_mesh_at(ij));
}

// Boundary vertex t, counter-clockwise in the triangles' sense (00 -> 10 -> 11 -> 01):
// the first row left to right, the last column down, the last row back, the first column up.
ivec2 boundary_vertex(int t) {
    ivec2 n = u_mesh_dims - 1;
    if (t < n.x) {
        return ivec2(t, 0);
    }
    t -= n.x;
    if (t < n.y) {
        return ivec2(n.x, t);
    }
    t -= n.y;
    if (t < n.x) {
        return ivec2(n.x - t, n.y);
    }
    return ivec2(0, n.y - (t - n.x));
}

#if WARP_CHECK_STAGE == 1
shared uint check_bad;         // the work group's counts of the boundary's edges
shared uint check_crossings;
#endif

void main() {
#if WARP_CHECK_STAGE == 1
    uint lane = gl_LocalInvocationID.x;
    if (lane == 0u) {
        check_bad = 0u;
        check_crossings = 0u;
    }
    barrier();
    int edges = 2 * (u_mesh_dims.x - 1) + 2 * (u_mesh_dims.y - 1);
    vec2 c = vertex_px(u_mesh_dims / 2);
    uint bad = 0u;
    uint crossings = 0u;
    for (int t = int(lane); t < edges; t += LOCAL_SIZE) {
        vec2 a = vertex_px(boundary_vertex(t)) - c;
        vec2 b = vertex_px(boundary_vertex((t + 1) % edges)) - c;
        // strictly counter-clockwise about c, with a margin against rounding (NaN: not)
        if (!(a.x * b.y - a.y * b.x > 1e-6 * length(a) * length(b))) {
            ++bad;
        }
        // crossings of the ray y = 0, x > 0 (half-open in y, so a vertex on it counts once)
        if ((a.y > 0.0) != (b.y > 0.0) && a.x + (b.x - a.x) * (-a.y / (b.y - a.y)) > 0.0) {
            ++crossings;
        }
    }
    atomicAdd(check_bad, bad);
    atomicAdd(check_crossings, crossings);
    barrier();
    if (lane != 0u) {
        return;
    }
    warp_check_bad = check_bad;
    warp_check_crossings = check_crossings;
    bool embedded = warp_check_boundary_simple() && warp_check_folded == 0u;
    uvec4 none = uvec4(0u, 1u, 1u, 0u);
    uint pixels = uint(u_target_size.x * u_target_size.y);
    uint cells = uint((u_mesh_dims.x - 1) * (u_mesh_dims.y - 1));
    warp_check_clear = embedded ? none : dispatch_groups((pixels + 3u) / 4u);
    // every cell where the boundary fails; else, if cells fold, stage 3 chooses
    bool local = warp_check_local();
    warp_check_scan = local ? none : dispatch_groups(cells);
    // stage 6 marks the listed cells' tiles, then stage 3 lists the blocks near them (where
    // cells fold inside a simple boundary), raising the keyed scan's groups from none
    int blocks_x = (u_mesh_dims.x - 1 + BLOCK - 1) / BLOCK;
    uint blocks = uint(blocks_x * ((u_mesh_dims.y - 1 + BLOCK - 1) / BLOCK));
    uvec4 marks = dispatch_groups(local ? warp_check_folded : 0u);
    uvec4 listing = dispatch_groups(local && warp_check_folded > 0u ? blocks : 0u);
    for (int k = 0; k < 3; ++k) {
        warp_check_data[WARP_CHECK_MARK_GROUPS + k] = marks[k];
        warp_check_data[WARP_CHECK_BLOCK_GROUPS + k] = listing[k];
        warp_check_data[WARP_CHECK_LIST_GROUPS + k] = none[k];
    }
#elif WARP_CHECK_STAGE == 3
    int blocks_x = (u_mesh_dims.x - 1 + BLOCK - 1) / BLOCK;
    int blocks = blocks_x * ((u_mesh_dims.y - 1 + BLOCK - 1) / BLOCK);
    int block = int(dispatch_item());
    if (block >= blocks) {
        return;
    }
    ivec2 b0 = ivec2(block % blocks_x, block / blocks_x) * BLOCK;   // its first vertex
    ivec2 b1 = min(b0 + BLOCK, u_mesh_dims - 1);                     // its last
    // The box of its vertices (scaled: warp_output_point is increasing in each coordinate).
    // Where all its cells are strictly positive, that of its boundary's: a point outside the
    // boundary's image has winding number 0 about it, so no positive cell covers it.
    bool folded = (warp_check_data[u_folded_blocks + block / 32] & (1u << uint(block % 32))) != 0u;
    int stride = folded ? 1 : b1.x - b0.x;   // inner rows: all or the two ends
    vec2 lo = warp_mesh_at(b0);
    vec2 hi = lo;
    for (int y = b0.y; y <= b1.y; ++y) {
        bool edge_row = y == b0.y || y == b1.y;
        for (int x = b0.x; x <= b1.x; x += edge_row ? 1 : stride) {
            vec2 p = warp_mesh_at(ivec2(x, y));
            lo = min(lo, p);
            hi = max(hi, p);
        }
    }
    // its pixels, one more on each side: the scan may round the vertices otherwise
    ivec2 first = max(ivec2(ceil(warp_output_point(lo))) - 1, ivec2(0));
    ivec2 last = min(ivec2(floor(warp_output_point(hi))) + 1, u_target_size - 1);
    if (all(lessThanEqual(first, last)) && warp_reaches_hot(first, last)) {
        uint k = atomicAdd(warp_check_data[WARP_CHECK_LISTED], 1u);
        warp_check_data[u_block_list + int(k)] = uint(block);
        // the keyed scan: a work group per listed block, enough for the k + 1 so far
        DISPATCH_RAISE(warp_check_data[WARP_CHECK_LIST_GROUPS],
                       warp_check_data[WARP_CHECK_LIST_GROUPS + 1], (k + 1u) * uint(LOCAL_SIZE))
    }
#elif WARP_CHECK_STAGE == 6
    uint k = dispatch_item();
    if (k >= warp_check_folded) {
        return;
    }
    int cell = int(warp_check_data[u_folded_list + int(k)]);
    int cells_x = u_mesh_dims.x - 1;
    ivec2 c = ivec2(cell % cells_x, cell / cells_x);
    vec2 p00 = vertex_px(c);
    vec2 p10 = vertex_px(c + ivec2(1, 0));
    vec2 p01 = vertex_px(c + ivec2(0, 1));
    vec2 p11 = vertex_px(c + 1);
    vec2 lo = min(min(p00, p10), min(p01, p11));
    vec2 hi = max(max(p00, p10), max(p01, p11));
    warp_mark_hot(max(ivec2(ceil(lo)), ivec2(0)), min(ivec2(floor(hi)), u_target_size - 1));
    int b = warp_block(c);
    atomicOr(warp_check_data[u_folded_blocks + b / 32], 1u << uint(b % 32));
#else
    uint j = dispatch_item();
    uint pixels = uint(u_target_size.x * u_target_size.y);
    if (j < (pixels + 3u) / 4u) {
        warp_winner4[j] = uvec4(0u);
    }
#endif
}
