// After the fused scan conversion (warp/cells.comp.glsl, WARP_CELLS_FUSED): each pixel that
// more than one triangle reached gets the colour of the one shown (the first in scan order),
// decoded from its key (cell row, cell column, triangle, source pixel in the cell). If more
// pixels were listed than the list holds, every covered pixel is redone instead. Dispatched
// indirectly, with the size the scan set as it listed them (warp_fixup_listed), so nothing is
// read back and nothing runs where no pixel was listed.
//
layout(local_size_x = LOCAL_SIZE) in;

#include "warp/cells_packed.glsl"
#include "warp/cells_key.glsl"
#include "common/lattice.glsl"

layout(std430, binding = BIND_WINNER) readonly buffer WarpWinner {
    uint warp_winner[];   // per target pixel, row-major: the shown triangle's key, 0 = none
};
uniform ivec2 u_target_size;
uniform ivec2 u_source_size;

bool overflowed() {
    return warp_fixup_count > uint(u_fixup_capacity);
}

void main() {
    uint j = dispatch_item();
    bool all_pixels = overflowed();
    if (j >= (all_pixels ? uint(u_target_size.x * u_target_size.y) : warp_fixup_count)) {
        return;
    }
    uint i = all_pixels ? j : warp_fixups[j];
    uint id = warp_winner[i];
    if (id == 0u) {
        return;   // uncovered (all pixels redone): the background stays
    }
    ivec2 s = lattice_source_pixel(warp_key_source_pixel(id), u_source_size);
    int width = u_target_size.x;
    warp_store(ivec2(int(i) % width, int(i) / width), warp_source_texel(s));
}
