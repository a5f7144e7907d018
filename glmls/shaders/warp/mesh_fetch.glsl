// f at vertex ij of the band (scaled coordinates), for the passes that read the deformed
// mesh at random: from the mesh texture (RG32F, vertex (i, j) of the band at texel (i, j):
// glmls.imaging.bands.MeshBands.texture; texel fetches are vectorised on llvmpipe, storage
// buffer reads go lane by lane), or, with WARP_MESH_BUFFER, from the mesh buffer itself,
// row-major, where a row of the band is wider than a texture: the corners of an image as wide
// as the GL limit, one vertex more than its pixels. Needs u_mesh_dims (vertices per row, rows).
#ifndef WARP_MESH_BUFFER
#define WARP_MESH_BUFFER 0
#endif

#if WARP_MESH_BUFFER
layout(std430, binding = BIND_DEFORMED) readonly buffer WarpMeshPoints {
    vec2 warp_mesh_points[];
};

vec2 warp_mesh_at(ivec2 ij) {
    return warp_mesh_points[ij.y * u_mesh_dims.x + ij.x];
}
#else
layout(binding = BIND_MESH) uniform sampler2D warp_mesh;

vec2 warp_mesh_at(ivec2 ij) {
    return texelFetch(warp_mesh, ij, 0).xy;
}
#endif
