// The lattice of voxel corners (glmls.volume.frame.CornerLattice), in source voxels, and f at
// its points as the construction holds them: a band of z layers of points, 3 floats a point
// (f in source voxels), layer-major, then rows, then points of a row.
#ifndef VOLUME_LATTICE_WRITE
#define VOLUME_LATTICE_WRITE 0
#endif

uniform ivec3 u_lattice_dims;   // points along x, y, z
uniform vec3 u_lattice_first;   // the first point's (x, y, z)
uniform vec3 u_lattice_last;    // the last point's (x, y, z): coordinates are clamped to it
uniform int u_lattice_grid;
// the first voxel of cell 0 (negative: in the margin before the volume), and the voxel past
// the last that a cell holds (the margin's past the volume's end), x, y, z
uniform ivec3 u_lattice_voxel_first;
uniform ivec3 u_lattice_voxel_end;
uniform int u_band_first;       // the first z layer of points held in the buffer
// the cells holding voxels of the volume, u_lattice_box_low .. u_lattice_box_high - 1; with
// u_lattice_box_first the others (the margin's) rank after all of them
uniform bool u_lattice_box_first;
uniform ivec3 u_lattice_box_low;
uniform ivec3 u_lattice_box_high;

#if VOLUME_LATTICE_WRITE
layout(std430, binding = BIND_VOLUME_LATTICE) writeonly buffer VolumeLattice {
    float volume_lattice_f[];
};
#else
layout(std430, binding = BIND_VOLUME_LATTICE) readonly buffer VolumeLattice {
    float volume_lattice_f[];
};
#endif

// Lattice point a (x, y, z indices), source voxels.
vec3 volume_lattice_point(ivec3 a) {
    return min(u_lattice_first + float(u_lattice_grid) * vec3(a), u_lattice_last);
}

#if !VOLUME_LATTICE_WRITE
// f at lattice point a, source voxels (its layer must be in the band).
vec3 volume_deformed(ivec3 a) {
    int i = 3 * (((a.z - u_band_first) * u_lattice_dims.y + a.y) * u_lattice_dims.x + a.x);
    return vec3(volume_lattice_f[i], volume_lattice_f[i + 1], volume_lattice_f[i + 2]);
}
#endif

// Cells in scan order of the source: index = (z ny + y) nx + x over the cells.
ivec3 volume_cell_of(uint index) {
    uint nx = uint(u_lattice_dims.x - 1);
    uint ny = uint(u_lattice_dims.y - 1);
    return ivec3(int(index % nx), int((index / nx) % ny), int(index / (nx * ny)));
}

uint volume_cell_total() {
    ivec3 cells = u_lattice_dims - 1;
    return uint(cells.x) * uint(cells.y) * uint(cells.z);
}

// A cell's rank among the cells covering a voxel (the least wins): its index, plus every
// cell's count where u_lattice_box_first ranks it after the volume's cells
uint volume_key_of(ivec3 cell) {
    uint nx = uint(u_lattice_dims.x - 1);
    uint ny = uint(u_lattice_dims.y - 1);
    uint index = (uint(cell.z) * ny + uint(cell.y)) * nx + uint(cell.x);
    bool margin = any(lessThan(cell, u_lattice_box_low)) ||
                  any(greaterThanEqual(cell, u_lattice_box_high));
    return index + (u_lattice_box_first && margin ? volume_cell_total() : 0u);
}

// The index of a cell of rank ``key``.
uint volume_index_of(uint key) {
    uint total = volume_cell_total();
    return key >= total ? key - total : key;
}

// Corner c (bits: 1 x, 2 y, 4 z) of a cell.
ivec3 volume_corner(ivec3 cell, int c) {
    return cell + ivec3(c & 1, (c >> 1) & 1, (c >> 2) & 1);
}
