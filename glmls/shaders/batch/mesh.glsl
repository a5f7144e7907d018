// The deformed meshes of a batch of images of one shape: every image's f at its lattice's
// vertices (scaled, as mls/points.comp.glsl writes them) one after the other in one buffer,
// u_mesh_stride vertices apart, and each image's scaling (centre, scale) to turn them into
// output pixels exactly as warp/frame.glsl's warp_output_point does for a single image.
layout(std430, binding = BIND_DEFORMED) readonly buffer BatchMesh {
    vec2 batch_mesh[];
};
layout(std430, binding = BIND_POINTS) readonly buffer BatchScaling {
    vec4 batch_scaling[];   // centre x, centre y, scale, 0
};

uniform ivec2 u_mesh_dims;    // vertices per row, rows (of every image's mesh)
uniform int u_mesh_stride;    // vertices from one image's mesh to the next
uniform vec2 u_origin;        // the output canvas's origin (warp/frame.glsl)

// Vertex ij of image k's mesh, in output pixels.
vec2 batch_vertex_px(int k, ivec2 ij) {
    vec4 sc = batch_scaling[k];
    vec2 scaled = batch_mesh[k * u_mesh_stride + ij.y * u_mesh_dims.x + ij.x];
    return scaled * sc.z + sc.xy - u_origin;
}
