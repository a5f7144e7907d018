// Decoding of the triangle keys of warp/cells.comp.glsl (WARP_CELLS_SOURCE): the source pixel
// that the winning triangle chose for a target pixel.
#include "common/lattice.glsl"

uniform int u_sub_bits;       // key layout, see warp/cells.comp.glsl
uniform int u_col_shift;
uniform int u_row_shift;

// id: a nonzero key (2^31 - the bit fields); the pixel in the lattice's coordinates.
ivec2 warp_key_source_pixel(uint id) {
    uint key = 0x80000000u - id;
    uint sub_mask = (1u << u_sub_bits) - 1u;
    ivec2 sub = ivec2(key & sub_mask, (key >> u_sub_bits) & sub_mask);
    uint columns = key & ((1u << u_row_shift) - 1u);
    return ivec2(columns >> u_col_shift, key >> u_row_shift) * u_grid + sub;
}
