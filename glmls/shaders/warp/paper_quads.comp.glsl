// The paper's "forward with polygon interpolation" as its pseudo-code says (method
// "paper-quads"; the float64 reference is glmls.core.paper_quads, whose rules this follows):
// squares S of four adjacent pixel centres, Q = f at its vertices, the pixel centres P in Q's
// bounding rectangle that are inside Q (crossing number of a ray towards +x, or within
// PAPER_TOLERANCE of an edge) and not yet marked get the colour of S's vertex whose deformed
// position is nearest to P.
//
// "Not yet marked", with the squares in row-major scan order, is "the first square in scan
// order that contains P": one invocation per square, in any order, records per pixel the key
// ~(4 k + v) with atomicMax (k the square's scan index, v its vertex nearest to P in the order
// 00, 10, 11, 01), so the smallest k wins whatever order the invocations run in, and the
// winner carries its vertex. 0 = not covered (the buffer is cleared to 0).
//
//   WARP_PAPER_STAGE 0: mark (the keys).
//                    1: (linear) each square writes, at the pixels it won, the source point
//                       of P by inverting Q's bilinear map: (x + a, y + b) with
//                       Q(a, b) = P, into u_map as (s.x, s.y, 0, covered) for
//                       warp/backward.frag.glsl.
//
// The squares are those of a glmls.core.mesh.MeshLattice of pixel centres (possibly with a
// margin past the image for the border modes), evaluated in bands that share a row
// (glmls.imaging.bands): each band's squares are its rows' squares, k is the whole lattice's.
// Each square's pixels: warp/paper_scan.glsl, which a batch's scan shares.
layout(local_size_x = LOCAL_SIZE) in;

#include "common/groups.glsl"
#include "warp/frame.glsl"
#include "warp/paper_scan.glsl"

layout(std430, binding = BIND_DEFORMED) readonly buffer WarpMesh {
    vec2 warp_mesh[];   // f at the band's pixel centres, scaled coordinates
};

uniform ivec2 u_mesh_dims;    // points per row, rows (of this band)
uniform int u_first_row;      // lattice row of the band's first row
uniform int u_offset;         // first square of this dispatch

vec2 vertex_px(int i) {
    return warp_output_point(warp_mesh[i]);
}

void main() {
    int squares_x = u_mesh_dims.x - 1;
    int square = u_offset + int(dispatch_item());
    if (square >= squares_x * (u_mesh_dims.y - 1)) {
        return;
    }
    int sy = square / squares_x;
    int sx = square - sy * squares_x;
    int i00 = sy * u_mesh_dims.x + sx;   // in the band
    vec2 q[4];   // 00, 10, 11, 01
    q[0] = vertex_px(i00);
    q[1] = vertex_px(i00 + 1);
    q[2] = vertex_px(i00 + u_mesh_dims.x + 1);
    q[3] = vertex_px(i00 + u_mesh_dims.x);
    int row = sy + u_first_row;
    uint k = uint(row) * uint(squares_x) + uint(sx);   // scan index in the whole lattice
    paper_scan(q, ivec2(sx, row), k, 0);
}
