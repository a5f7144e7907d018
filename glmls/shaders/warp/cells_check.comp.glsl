// Is the deformed mesh an embedding (no pixel covered by two triangles)? The fast pass
// (warp/cells.comp.glsl with WARP_CELLS_FAST) writes colours without keys or atomics and
// counts the cells that are not strictly positively oriented; this shader adds the test of
// the mesh's boundary and, if either fails, sizes the clear and the keyed scan that redo the
// picture (indirect dispatches: nothing is read back).
//
// Why that suffices: for a triangle mesh of a disc whose triangles are all positively
// oriented, the number of triangles over a point (off the edges) is the winding number of
// the boundary's image around it; if the boundary is a simple closed curve that number is
// 0 or 1. A simple test of simplicity, sufficient not necessary: the boundary is star-shaped
// from the image c of the mesh's centre vertex, every edge turning strictly counter-clockwise
// about c (in the triangles' sense) and the whole going around exactly once (one crossing of
// the ray from c to +x). Strong deformations of the border fail it and take the keyed pass.
//
//   WARP_CHECK_STAGE 0: one invocation per boundary edge;
//                    1: one invocation, the dispatch sizes;
//                    2: the winner clear (dispatched with the sizes of stage 1).
layout(local_size_x = LOCAL_SIZE) in;

#include "warp/cells_packed.glsl"
#include "warp/frame.glsl"

layout(std430, binding = BIND_DEFORMED) readonly buffer WarpMesh {
    vec2 warp_mesh[];   // f at the mesh vertices, scaled coordinates
};
layout(std430, binding = BIND_WINNER) writeonly buffer WarpWinner {
    uvec4 warp_winner4[];   // the keys, four per element
};

uniform ivec2 u_mesh_dims;    // vertices per row, rows (the whole mesh)
uniform ivec2 u_target_size;

vec2 vertex_px(ivec2 ij) {
    return warp_output_point(warp_mesh[ij.y * u_mesh_dims.x + ij.x]);
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

void main() {
#if WARP_CHECK_STAGE == 0
    int edges = 2 * (u_mesh_dims.x - 1) + 2 * (u_mesh_dims.y - 1);
    int t = int(gl_GlobalInvocationID.x);
    if (t >= edges) {
        return;
    }
    vec2 c = vertex_px(u_mesh_dims / 2);
    vec2 a = vertex_px(boundary_vertex(t)) - c;
    vec2 b = vertex_px(boundary_vertex((t + 1) % edges)) - c;
    // strictly counter-clockwise about c, with a margin against rounding
    if (!(a.x * b.y - a.y * b.x > 1e-6 * length(a) * length(b))) {
        atomicAdd(warp_check_bad, 1u);
    }
    // crossings of the ray y = 0, x > 0 (half-open in y, so a vertex on it counts once)
    if ((a.y > 0.0) != (b.y > 0.0) && a.x + (b.x - a.x) * (-a.y / (b.y - a.y)) > 0.0) {
        atomicAdd(warp_check_crossings, 1u);
    }
#elif WARP_CHECK_STAGE == 1
    bool embedded = warp_check_bad == 0u && warp_check_crossings == 1u;
    uvec4 none = uvec4(0u, 1u, 1u, 0u);
    uint pixels = uint(u_target_size.x * u_target_size.y);
    uint cells = uint((u_mesh_dims.x - 1) * (u_mesh_dims.y - 1));
    warp_check_clear = embedded ? none : dispatch_groups((pixels + 3u) / 4u);
    warp_check_scan = embedded ? none : dispatch_groups(cells);
#else
    uint j = dispatch_item();
    uint pixels = uint(u_target_size.x * u_target_size.y);
    if (j < (pixels + 3u) / 4u) {
        warp_winner4[j] = uvec4(0u);
    }
#endif
}
