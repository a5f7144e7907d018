// Which meshes of a batch's chunk are embeddings (no pixel covered by two triangles), the
// test of the single warp's fast pass (warp/cells_check.comp.glsl, which says why it
// suffices) for every image at once, on the vertices batch/cells.comp.glsl scans: item c <
// cells of image k tests cell c (both triangles strictly positive), the next items the
// boundary's edges (each turning strictly counter-clockwise about the centre vertex's image,
// and the crossings of the ray from it to +x). batch_check[k] counts (cells not positive,
// edges not turning, crossings): an embedding is (0, 0, 1), whose colours the fused scan
// writes without keys. BATCH_CHECK_STAGE 2, after: one invocation per image lists it for the
// scan of the embeddings or of the others (batch/lists.glsl).
layout(local_size_x = LOCAL_SIZE) in;

#ifndef BATCH_CHECK_STAGE
#define BATCH_CHECK_STAGE 1
#endif

#include "common/groups.glsl"
#include "common/lattice.glsl"
#include "batch/mesh.glsl"
#include "warp/coverage.glsl"

layout(std430, binding = BIND_BATCH_CHECK) buffer BatchCheck {
    uvec4 batch_check[];   // per image: cells not positive, edges not turning, crossings, 0
};
#include "batch/lists.glsl"
uniform int u_images;
uniform int u_offset;   // first item of this dispatch

// Boundary vertex t, counter-clockwise in the triangles' sense (00 -> 10 -> 11 -> 01).
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

void main() {
    int cells_x = u_mesh_dims.x - 1;
    int cells = cells_x * (u_mesh_dims.y - 1);
#if BATCH_CHECK_STAGE == 2
    // one invocation per image: list it for the scan of the embeddings or of the others
    int image = u_offset + int(dispatch_item());
    if (image >= u_images) {
        return;
    }
    uint part = batch_check[image].xyz == uvec3(0u, 0u, 1u) ? 0u : 1u;
    uint n = part == 0u ? atomicAdd(batch_listed.x, 1u) : atomicAdd(batch_listed.y, 1u);
    batch_list[part * uint(u_images) + n] = uint(image);
    DISPATCH_RAISE(batch_groups[part].x, batch_groups[part].y, (n + 1u) * uint(cells))
#else
    int edges = 2 * (u_mesh_dims.x - 1) + 2 * (u_mesh_dims.y - 1);
    int item = u_offset + int(dispatch_item());
    int k = item / (cells + edges);
    if (k >= u_images) {
        return;
    }
    int i = item - k * (cells + edges);
    if (i < cells) {
        ivec2 c00 = ivec2(i % cells_x, i / cells_x);
        vec2 p00 = batch_vertex_px(k, c00);
        vec2 p10 = batch_vertex_px(k, c00 + ivec2(1, 0));
        vec2 p01 = batch_vertex_px(k, c00 + ivec2(0, 1));
        vec2 p11 = batch_vertex_px(k, c00 + 1);
        // strictly positive by a margin far above the rounding of the vertices (the scan's
        // own may differ from these by an ulp where a compiler fuses their multiply-add)
        // (the edges' lengths bounded by their x and y extents: no square roots)
        vec2 top = max(max(abs(p00), abs(p10)), max(abs(p01), abs(p11)));
        vec2 span = abs(p10 - p00) + abs(p11 - p00) + abs(p01 - p00);
        float margin = 1e-6 * (max(top.x, top.y) + 1.0) * (span.x + span.y);
        if (!(edge(p00, p10, p11) > margin && edge(p00, p11, p01) > margin)) {
            atomicAdd(batch_check[k].x, 1u);
        }
        return;
    }
    int t = i - cells;
    vec2 c = batch_vertex_px(k, u_mesh_dims / 2);
    vec2 a = batch_vertex_px(k, boundary_vertex(t)) - c;
    vec2 b = batch_vertex_px(k, boundary_vertex((t + 1) % edges)) - c;
    // strictly counter-clockwise about c, with a margin against rounding (NaN: not)
    if (!(a.x * b.y - a.y * b.x > 1e-6 * length(a) * length(b))) {
        atomicAdd(batch_check[k].y, 1u);
    }
    // crossings of the ray y = 0, x > 0 (half-open in y, so a vertex on it counts once)
    if ((a.y > 0.0) != (b.y > 0.0) && a.x + (b.x - a.x) * (-a.y / (b.y - a.y)) > 0.0) {
        atomicAdd(batch_check[k].z, 1u);
    }
#endif
}
