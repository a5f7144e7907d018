// Scan conversion of the deformed mesh in a compute shader: the rasterizer's job for the
// "quads" method, without its per-triangle setup cost (llvmpipe spends ~0.25 us per triangle,
// 0.5 s for the 2 million triangles of a 1024^2 image at grid 1).
//
// One invocation per mesh cell: the cell's two triangles (00, 10, 11) and (00, 11, 01) are
// tested at every pixel centre of their bounding box, and each covered pixel records the
// triangle's key 1 + (cell row << 16 | cell column << 1 | 0 or 1) with atomicMax (cells up to
// 32767 per side). The largest key wins whatever order the invocations run in, and keys are
// ordered as the triangles of one draw call in row-major cell order, so this is OpenGL's rule
// (later primitives on top): where cells fold, the cell with the larger source row, then
// column, shows, and warp_cells.frag.glsl fills the pixel from that triangle. (Shifts, not a
// row-major index, so that the fill decodes it without an integer division per pixel.)
//
// Coverage is OpenGL's: pixel centres strictly inside, and on an edge only for one of the two
// triangles that share it (a top-left style tie rule). Each edge function is computed from
// the edge's endpoints in mesh-index order, with `precise`, so the two triangles on either
// side of an edge see exactly opposite values and no pixel is lost or drawn twice on a seam.
layout(local_size_x = 64) in;

layout(std430, binding = 2) readonly buffer WarpMesh {
    vec2 warp_mesh[];   // f at the mesh vertices, scaled coordinates
};
layout(std430, binding = 4) buffer WarpWinner {
    uint warp_winner[];  // per target pixel, row-major: the top triangle's key, 0 = none
};

uniform vec2 u_center;        // scaled -> pixels
uniform float u_scale;
uniform ivec2 u_target_size;  // W, H in pixels
uniform ivec2 u_mesh_dims;    // vertices per row, rows (of this band)
uniform int u_first_row;      // mesh row of the band's first row (bands: see WarpPipeline)
uniform int u_offset;         // first cell of this dispatch

vec2 vertex_px(int i) {
    return warp_mesh[i] * u_scale + u_center;
}

// The edge function of edge (a, b), a before b in mesh order, at p.
float edge(vec2 a, vec2 b, vec2 p) {
    precise float e = (b.x - a.x) * (p.y - a.y) - (b.y - a.y) * (p.x - a.x);
    return e;
}

// Is an edge value e (already multiplied by the triangle's orientation) covering? d is the
// edge's direction along the triangle's counter-clockwise boundary.
bool covers(float e, vec2 d) {
    return e > 0.0 || (e == 0.0 && (d.y > 0.0 || (d.y == 0.0 && d.x > 0.0)));
}

void main() {
    int cells_x = u_mesh_dims.x - 1;
    int cell = u_offset + int(gl_GlobalInvocationID.x);
    if (cell >= cells_x * (u_mesh_dims.y - 1)) {
        return;
    }
    int cy = cell / cells_x;
    int cx = cell - cy * cells_x;
    int i00 = cy * u_mesh_dims.x + cx;   // in the band
    vec2 p00 = vertex_px(i00);
    vec2 p10 = vertex_px(i00 + 1);
    vec2 p01 = vertex_px(i00 + u_mesh_dims.x);
    vec2 p11 = vertex_px(i00 + u_mesh_dims.x + 1);

    // Orientation of each triangle; degenerate ones cover nothing (as in OpenGL).
    float s0 = sign(edge(p00, p10, p11));
    float s1 = sign(edge(p00, p11, p01));
    if (s0 == 0.0 && s1 == 0.0) {
        return;
    }
    vec2 lo = min(min(p00, p10), min(p01, p11));
    vec2 hi = max(max(p00, p10), max(p01, p11));
    ivec2 first = max(ivec2(ceil(lo)), ivec2(0));
    ivec2 last = min(ivec2(floor(hi)), u_target_size - 1);
    uint id0 = (uint(cy + u_first_row) << 16 | uint(cx) << 1) + 1u;   // triangle 0's key
    for (int y = first.y; y <= last.y; ++y) {
        for (int x = first.x; x <= last.x; ++x) {
            vec2 p = vec2(x, y);
            // the five edges, in mesh-index order (00 < 10 < 01 < 11)
            float e_a = edge(p00, p10, p);   // 00 -> 10
            float e_b = edge(p10, p11, p);   // 10 -> 11
            float e_d = edge(p00, p11, p);   // the diagonal 00 -> 11
            float e_c = edge(p01, p11, p);   // 01 -> 11
            float e_e = edge(p00, p01, p);   // 00 -> 01
            uint id = 0u;
            // triangle 0: 00 -> 10 -> 11 -> 00
            if (s0 != 0.0 && covers(s0 * e_a, s0 * (p10 - p00)) &&
                covers(s0 * e_b, s0 * (p11 - p10)) && covers(-s0 * e_d, s0 * (p00 - p11))) {
                id = id0;
            }
            // triangle 1: 00 -> 11 -> 01 -> 00 (drawn after triangle 0: it wins)
            if (s1 != 0.0 && covers(s1 * e_d, s1 * (p11 - p00)) &&
                covers(-s1 * e_c, s1 * (p01 - p11)) && covers(-s1 * e_e, s1 * (p00 - p01))) {
                id = id0 + 1u;
            }
            if (id != 0u) {
                atomicMax(warp_winner[y * u_target_size.x + x], id);
            }
        }
    }
}
