// The deformed meshes of a batch of images of one shape: every image's f at its lattice's
// vertices (scaled, as mls/points.comp.glsl writes them) one after the other in a table
// (common/table.glsl, RG32F), u_mesh_stride vertices apart, and each image's scaling (centre,
// scale) in a table of its own, to turn them into output pixels exactly as warp/frame.glsl's
// warp_output_point does for a single image (glmls.batch.gpu.BatchQuads.meshes). Tables: a
// cell's vertices differ from lane to lane, which llvmpipe's texel fetches gather at once.
#include "common/table.glsl"

layout(binding = BIND_BATCH_MESH) uniform sampler2D batch_mesh_table;
layout(binding = BIND_BATCH_SCALING) uniform sampler2D batch_scaling_table;

uniform ivec2 u_mesh_dims;    // vertices per row, rows (of every image's mesh)
uniform int u_mesh_stride;    // vertices from one image's mesh to the next
uniform vec2 u_origin;        // the output canvas's origin (warp/frame.glsl)

// Vertex ij of image k's mesh, in output pixels.
vec2 batch_vertex_px(int k, ivec2 ij) {
    vec4 sc = TABLE_FETCH(batch_scaling_table, k);   // centre x, centre y, scale, 0
    vec2 scaled = TABLE_FETCH(batch_mesh_table, k * u_mesh_stride + ij.y * u_mesh_dims.x + ij.x).xy;
    return scaled * sc.z + sc.xy - u_origin;
}

// The source point (lattice pixels, before u_lattice_offset) at output pixel x of the triangle
// (a, b, d) of cell g whose corners are the mesh vertices g, g + kb, g + kc: the corner 00
// plus the offset in the cell, as warp/cells.frag.glsl computes it for a single image (needs
// common/lattice.glsl). batch/resolve.frag.glsl and the bilinear scan of the embeddings
// (batch/cells.comp.glsl, BATCH_CELLS_LINEAR) share it, so that both give the same floats.
vec2 batch_source_point(vec2 a, vec2 b, vec2 d, ivec2 g, ivec2 kb, ivec2 kc, vec2 x) {
    float area = (b.x - a.x) * (d.y - a.y) - (b.y - a.y) * (d.x - a.x);
    float nb = (x.x - a.x) * (d.y - a.y) - (x.y - a.y) * (d.x - a.x);   // lb * area
    float nd = (b.x - a.x) * (x.y - a.y) - (b.y - a.y) * (x.x - a.x);   // ld * area
    vec2 s00 = lattice_corner(g);
    vec2 sb = lattice_corner(g + kb) - s00;
    vec2 sd = lattice_corner(g + kc) - s00;
    return s00 + (sb * nb + sd * nd) / area;
}
