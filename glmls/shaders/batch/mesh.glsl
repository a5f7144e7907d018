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
