// An output slab of the volume's canvas, its voxels taken x fastest, then rows, then slices:
// voxel i's place in the slab.

uniform ivec3 u_slab_size;   // W, H and slices of the output slab

ivec3 volume_voxel(int i) {
    return ivec3(i % u_slab_size.x, (i / u_slab_size.x) % u_slab_size.y,
                 i / (u_slab_size.x * u_slab_size.y));
}
