// Which meshes of a batch's chunk are embeddings (no pixel covered by two triangles), the
// test of the single warp's fast pass (warp/cells_check.comp.glsl, which says why it
// suffices: all triangles positive and a simple boundary) for every image at once, on the
// vertices batch/cells.comp.glsl scans: item c < cells of image k tests cell c (both
// triangles strictly positive), the next items the boundary's edges (each turning strictly
// counter-clockwise about the centre vertex's image, and the crossings of the ray from it to
// +x: a star-shaped boundary). batch_check[k] counts (cells not positive, edges not turning,
// crossings, and w: 1 where stage 2 showed the boundary simple): an embedding is (0, 0, 1, *)
// or (0, *, *, 1), whose colours the fused scan writes without keys. BATCH_CHECK_STAGE 2,
// after: one invocation per image lists it for the scan of the embeddings or of the others
// (batch/lists.glsl); a mesh whose cells are all positive but whose boundary is not
// star-shaped (a long strip bent along its length: a text line) has its boundary tested edge
// against edge there, up to BATCH_SIMPLE_EDGES edges.
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

// The most boundary edges whose pairs stage 2 tests (a 224 x 224 image at grid 4 has 224): a
// lane's loop over their pairs, 32,640 at most, stays under llvmpipe's 65,535 iterations of a
// loop.
#ifndef BATCH_SIMPLE_EDGES
#define BATCH_SIMPLE_EDGES 256
#endif

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

float boundary_cross(vec2 u, vec2 v) {
    precise float c = u.x * v.y - u.y * v.x;
    return c;
}

// Squared distance of point p to the segment from a by ab.
float to_segment(vec2 p, vec2 a, vec2 ab) {
    vec2 rel = p - a;
    float t = clamp(dot(rel, ab) / max(dot(ab, ab), 1e-30), 0.0, 1.0);
    vec2 gap = rel - t * ab;
    return dot(gap, gap);
}

// Whether segments ab and pq cross or come within distance tol of each other: the distance
// of two segments that do not cross is the least of their ends' distances to the other
// (NaN: near).
bool segments_near(vec2 a, vec2 b, vec2 p, vec2 q, float tol) {
    vec2 ab = b - a, pq = q - p;
    float sp = boundary_cross(ab, p - a), sq = boundary_cross(ab, q - a);
    float sa = boundary_cross(pq, a - p), sb = boundary_cross(pq, b - p);
    if (sp * sq < 0.0 && sa * sb < 0.0) {
        return true;
    }
    float closest = min(min(to_segment(p, a, ab), to_segment(q, a, ab)),
                        min(to_segment(a, p, pq), to_segment(b, p, pq)));
    return !(closest > tol * tol);
}

// Whether the boundary of mesh k is a simple closed curve, shown with a margin far above the
// rounding of its vertices: every two edges that share no vertex apart by more than it, and
// no edge turning back along the one before it. False (not shown) beyond BATCH_SIMPLE_EDGES
// edges. Sufficient, with every cell positive, for an embedding (warp/cells_check.comp.glsl).
bool simple_boundary(int k) {
    int edges = 2 * (u_mesh_dims.x - 1) + 2 * (u_mesh_dims.y - 1);
    if (edges > BATCH_SIMPLE_EDGES) {
        return false;
    }
    float top = 0.0;
    for (int t = 0; t < edges; ++t) {
        vec2 v = abs(batch_vertex_px(k, boundary_vertex(t)));
        top = max(top, max(v.x, v.y));
    }
    // a distance far above float32's rounding of coordinates up to top (the segments' ends
    // and their distances carry a few ulps of it)
    float tol = 1e-5 * (top + 1.0);
    for (int i = 0; i < edges; ++i) {
        vec2 a = batch_vertex_px(k, boundary_vertex(i));
        vec2 b = batch_vertex_px(k, boundary_vertex((i + 1) % edges));
        vec2 p = batch_vertex_px(k, boundary_vertex((i + 2) % edges));
        vec2 ab = b - a, bp = p - b;
        float turn = boundary_cross(ab, bp);
        if (!(abs(turn) > tol * (abs(ab.x) + abs(ab.y) + abs(bp.x) + abs(bp.y)) ||
              dot(ab, bp) > 0.0)) {
            return false;  // the next edge turns back along this one
        }
        int last = i == 0 ? edges - 1 : edges;  // edge edges - 1 shares vertex 0 with edge 0
        for (int j = i + 2; j < last; ++j) {
            vec2 q = batch_vertex_px(k, boundary_vertex((j + 1) % edges));
            if (segments_near(a, b, p, q, tol)) {
                return false;
            }
            p = q;
        }
    }
    return true;
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
    uvec3 counts = batch_check[image].xyz;
    bool embedding = counts == uvec3(0u, 0u, 1u);
    if (!embedding && counts.x == 0u && simple_boundary(image)) {
        batch_check[image].w = 1u;
        embedding = true;
    }
    uint part = embedding ? 0u : 1u;
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
