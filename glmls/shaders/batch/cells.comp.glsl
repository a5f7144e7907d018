// The quads of a batch of images scan-converted in one dispatch: one invocation per cell of
// every image's mesh (cell c of image k is item k * cells + c). Each cell does what
// warp/cells.comp.glsl's keyed pass does for a single image:
// the same edge functions, coverage and tie rules (warp/coverage.glsl), the same keys (cell
// row | cell column | triangle | [WARP_CELLS_SOURCE: the nearest source pixel in the cell])
// kept per pixel with atomicMax, so that where cells fold the FIRST in row-major scan order
// shows, and the pixels equal the single image's. Image k's pixels are the k-th block of
// u_target_size.x * u_target_size.y entries of the winner buffer: row k * H + y of an atlas
// of the images' output canvases stacked top to bottom (batch/resolve.frag.glsl fills it).
//
// WARP_CELLS_FUSED (nearest, RGBA8 sources and atlas, with WARP_CELLS_SOURCE): as the single
// warp's fused scan, every triangle also writes its source texel into the atlas (the sources
// are an atlas too, image k's rows k * source H ...), and one that finds its pixel taken
// lists it for batch/fixup.comp.glsl, which writes the winner's texel there. Images whose
// meshes are embeddings (batch/check.comp.glsl) skip the keys: no pixel of theirs is covered
// twice (BATCH_CELLS_PASS 1 scans only them, the single warp's fast pass). WARP_SOURCE_BYTES:
// the sources are the caller's bytes and the atlas a texture filled with the background
// beforehand (batch/bytes.glsl), so an embedding's scan writes its texels and nothing else.
// BATCH_CELLS_LINEAR (bilinear images, with BATCH_CELLS_PASS): the embeddings' scan (1)
// colours each covered pixel itself, no key kept: the source point as batch/resolve.frag.glsl
// computes it from a key (lattice_source_point), sampled as it samples (batch/sample.glsl),
// stored into the atlas (TEXEL_TARGET, in the atlas's format BATCH_ATLAS_FORMAT: an image
// store converts to 8 bits as a framebuffer write does) and, with BATCH_CELLS_LABELS, the
// label image at the key's nearest source pixel into the labels' atlas; the others' scan (2)
// keeps the keys, which the resolve draw then fills.
// A cell too large for one invocation on a driver that caps its loops (llvmpipe) is walked
// in pieces by more invocations (common/pieces.glsl).
layout(local_size_x = LOCAL_SIZE) in;

#ifndef WARP_CELLS_FUSED
#define WARP_CELLS_FUSED 0
#endif
// With WARP_CELLS_FUSED: 0 every image, 1 the images whose mesh is an embedding only (no
// keys, both triangles of every cell positive: the single warp's fast pass), 2 the others;
// 1 and 2 take the images batch/check.comp.glsl listed for them (batch/lists.glsl).
#ifndef BATCH_CELLS_PASS
#define BATCH_CELLS_PASS 0
#endif
#ifndef BATCH_CELLS_LINEAR
#define BATCH_CELLS_LINEAR 0
#endif
#ifndef BATCH_CELLS_LABELS
#define BATCH_CELLS_LABELS 0
#endif

#include "common/groups.glsl"
#include "common/lattice.glsl"
#include "batch/mesh.glsl"
#include "warp/coverage.glsl"
#include "common/pieces.glsl"
#if WARP_CELLS_FUSED
uniform ivec2 u_source_size;  // W, H of one source image
#include "warp/cells_packed.glsl"
#endif
#if WARP_CELLS_FUSED || BATCH_CELLS_LINEAR
layout(std430, binding = BIND_BATCH_CHECK) readonly buffer BatchCheck {
    uvec4 batch_check[];   // per image, batch/check.comp.glsl's counts
};
#include "batch/lists.glsl"
#endif
#if BATCH_CELLS_LINEAR && BATCH_CELLS_PASS == 1
layout(binding = BIND_SOURCE) uniform sampler2DArray u_sources;
uniform ivec2 u_source_size;  // W, H of one source image
#include "batch/sample.glsl"
layout(BATCH_ATLAS_FORMAT, binding = BIND_TEXEL_TARGET) writeonly uniform image2D batch_atlas;
#if BATCH_CELLS_LABELS
layout(binding = BIND_LABEL_SOURCES) uniform sampler2DArray u_label_sources;
layout(BATCH_LABEL_FORMAT, binding = BIND_BATCH_LABEL_IMAGE) writeonly uniform image2D
    batch_label_atlas;
#endif
#endif

layout(std430, binding = BIND_WINNER) buffer WarpWinner {
    uint warp_winner[];  // per atlas pixel, row-major: the shown triangle's key, 0 = none
};

uniform ivec2 u_target_size;  // W, H of one image's output canvas
uniform int u_images;         // images in the batch
uniform int u_offset;         // first item of this dispatch
uniform int u_sub_bits;       // key layout, see warp/cells.comp.glsl
uniform int u_col_shift;
uniform int u_row_shift;

void main() {
    int cells_x = u_mesh_dims.x - 1;
    int cells = cells_x * (u_mesh_dims.y - 1);
#if (WARP_CELLS_FUSED || BATCH_CELLS_LINEAR) && BATCH_CELLS_PASS != 0
    // the cells of the images listed for this scan (an indirect dispatch, batch/lists.glsl)
    int item = int(dispatch_item());
    int listed = item / cells;
    uint part = uint(BATCH_CELLS_PASS - 1);
    if (listed >= int(part == 0u ? batch_listed.x : batch_listed.y)) {
        return;
    }
    int k = int(batch_list[part * uint(u_images) + uint(listed)]);
    int cell = item - listed * cells;
    // an image whose mesh batch/check.comp.glsl showed to be an embedding covers each pixel
    // once: its colours need no keys (the single warp's fast pass)
    const bool keyed = BATCH_CELLS_PASS == 2;
#else
    int item = u_offset + int(dispatch_item());
    int k = item / cells;
    if (k >= u_images) {
        return;
    }
    int cell = item - k * cells;
#if WARP_CELLS_FUSED
    bool keyed = batch_check[k].xyz != uvec3(0u, 0u, 1u);
#endif
#endif
    int cy = cell / cells_x;
    int cx = cell - cy * cells_x;
    ivec2 c00 = ivec2(cx, cy);
    vec2 p00 = batch_vertex_px(k, c00);
    vec2 p10 = batch_vertex_px(k, c00 + ivec2(1, 0));
    vec2 p01 = batch_vertex_px(k, c00 + ivec2(0, 1));
    vec2 p11 = batch_vertex_px(k, c00 + 1);

    float s0 = sign(edge(p00, p10, p11));
    float s1 = sign(edge(p00, p11, p01));
#if BATCH_CELLS_PASS == 1
    // both 1 (batch/check.comp.glsl showed them positive by a margin above the rounding of
    // the vertices): constants, the compiler drops the other orientations' code per pixel
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
    int row = cy;
    uint id0 = 0x80000000u - (uint(row) << u_row_shift | uint(cx) << u_col_shift);
    uint id1 = id0 - (1u << (2 * u_sub_bits));
#if WARP_CELLS_SOURCE
    ivec2 cell_lo = ivec2(cx, row) * u_grid;
    ivec2 cell_hi = min(cell_lo + u_grid - 1, u_lattice_size - 1);
    vec2 s00 = lattice_corner(ivec2(cx, row));
    vec2 size = lattice_corner(ivec2(cx, row) + 1) - s00;
    float inv0 = 1.0 / edge(p00, p10, p11);
    float inv1 = 1.0 / edge(p00, p11, p01);
#endif
    float s2 = sign(edge(p10, p11, p01));
    float s3 = sign(edge(p10, p01, p00));
    bool convex = s0 != 0.0 && s0 == s1 && s0 == s2 && s0 == s3;
    RowBounds bounds = row_bounds(p00, p10, p11, p01, s0, convex);
    RowWalk walk = row_walk(bounds, first, last);
    int base = k * u_target_size.x * u_target_size.y;
    bool positive = s0 > 0.0 && s1 > 0.0;
    bool tie_a = edge_tie(p10 - p00);
    bool tie_b = edge_tie(p11 - p10);
    bool tie_c = edge_tie(p01 - p11);
    bool tie_e = edge_tie(p00 - p01);
    bool tie_d = edge_tie(p11 - p00);
    while (row_walk_next(walk, bounds, first, last)) {
        bool in_row = walk.in_row;
        int column = walk.x;
        int y = walk.y;
        vec2 p = vec2(column, y);
        uint id = 0u;
#if WARP_CELLS_SOURCE
        vec2 t = vec2(0.0);
#endif
        if (positive) {
            // both triangles positive: the diagonal tells which one may cover p, then that
            // one's two other edges, from the same end points in mesh-index order as below
            // (the same values, the same coverage: warp/cells.comp.glsl's fast pass)
            float e_d = edge(p00, p11, p);
            bool upper = covers_by(e_d, tie_d);
            float e_1 = edge(upper ? p01 : p00, upper ? p11 : p10, p);   // e_c or e_a
            float e_2 = edge(upper ? p00 : p10, upper ? p01 : p11, p);   // e_e or e_b
            float flip = upper ? -1.0 : 1.0;
            bool inside = covers_by(flip * e_1, upper ? tie_c : tie_a) &&
                          covers_by(flip * e_2, upper ? tie_e : tie_b);
            id = inside ? (upper ? id1 : id0) : 0u;
#if WARP_CELLS_SOURCE
            t = upper ? vec2(-e_2 * inv1, 1.0 + e_1 * inv1) : vec2(1.0 - e_2 * inv0, e_1 * inv0);
#endif
        } else {
            float e_a = edge(p00, p10, p);
            float e_b = edge(p10, p11, p);
            float e_d = edge(p00, p11, p);
            float e_c = edge(p01, p11, p);
            float e_e = edge(p00, p01, p);
            if (s1 != 0.0 && covers(s1 * e_d, s1 * (p11 - p00)) &&
                covers(-s1 * e_c, s1 * (p01 - p11)) && covers(-s1 * e_e, s1 * (p00 - p01))) {
                id = id1;
#if WARP_CELLS_SOURCE
                t = vec2(-e_e * inv1, 1.0 + e_c * inv1);
#endif
            }
            if (s0 != 0.0 && covers(s0 * e_a, s0 * (p10 - p00)) &&
                covers(s0 * e_b, s0 * (p11 - p10)) && covers(-s0 * e_d, s0 * (p00 - p11))) {
                id = id0;
#if WARP_CELLS_SOURCE
                t = vec2(1.0 - e_b * inv0, e_a * inv0);
#endif
            }
        }
        id = in_row ? id : 0u;
#if BATCH_CELLS_LINEAR && BATCH_CELLS_PASS == 1
        // the triangle of id, as a key names it: 0 (00, 10, 11), 1 (00, 11, 01)
        bool second = id == id1;
#endif
#if WARP_CELLS_SOURCE
        ivec2 sp = clamp(ivec2(floor(s00 + t * size + 0.5)), cell_lo, cell_hi) - cell_lo;
        id -= id != 0u ? uint(sp.y << u_sub_bits | sp.x) : 0u;
#endif
        int i = base + y * u_target_size.x + column;
#if WARP_CELLS_FUSED
        uint before = 0u;
        if (keyed) {
            before = atomicMax(warp_winner[i], id);
        }
        ivec2 source = cell_lo + sp + ivec2(0, k * u_source_size.y);
        ivec2 target = ivec2(column, k * u_target_size.y + y);
#if WARP_SOURCE_BYTES
        if (id != 0u) {   // the bytes read only where drawn (each lane's load is its own)
            warp_store(target, warp_source_texel(source));
        }
#else
        warp_store(id != 0u ? target : ivec2(-1), warp_source_texel(source));
#endif
        if (before != 0u && id != 0u) {
            uint n = atomicAdd(warp_fixup_count, 1u);
            if (n < uint(u_fixup_capacity)) {
                warp_fixups[n] = uint(i);
            }
            warp_fixup_listed(n, uint(u_images * u_target_size.x * u_target_size.y));
        }
#elif BATCH_CELLS_LINEAR && BATCH_CELLS_PASS == 1
        if (id != 0u) {   // no other triangle covers it: no key to keep
            ivec2 kb = second ? ivec2(1, 1) : ivec2(1, 0);
            ivec2 kc = second ? ivec2(0, 1) : ivec2(1, 1);
            vec2 s = lattice_source_point(p00, second ? p11 : p10, second ? p01 : p11, c00, kb,
                                        kc, p);
            ivec2 at = ivec2(column, k * u_target_size.y + y);
            imageStore(batch_atlas, at, batch_sample(s + vec2(u_lattice_offset), k));
#if BATCH_CELLS_LABELS
            // the key's source pixel, as batch/resolve.frag.glsl reads the labels there
            ivec2 nearest = border_pixel(cell_lo + sp + u_lattice_offset, u_source_size);
            imageStore(batch_label_atlas, at, texelFetch(u_label_sources, ivec3(nearest, k), 0));
#endif
        }
#else
        atomicMax(warp_winner[i], id);
#endif
    }
}
