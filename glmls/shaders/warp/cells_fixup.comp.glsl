// After the fused scan conversion (warp/cells.comp.glsl, WARP_CELLS_FUSED): each pixel that
// more than one triangle reached gets the colour of the one shown (the first in scan order),
// decoded from its key (cell row, cell column, triangle, source pixel in the cell). If more
// pixels were listed than the list holds, every covered pixel is redone instead. Dispatched
// indirectly, with the size WARP_FIXUP_ARGS wrote from the count, so nothing is read back.
//
layout(local_size_x = LOCAL_SIZE) in;

#include "warp/cells_packed.glsl"
#include "warp/cells_key.glsl"
#include "common/lattice.glsl"

layout(std430, binding = BIND_WINNER) readonly buffer WarpWinner {
    uint warp_winner[];   // per target pixel, row-major: the shown triangle's key, 0 = none
};
layout(std430, binding = BIND_FIXUP_DISPATCH) buffer WarpFixupDispatch {
    uvec4 warp_fixup_groups;   // x, y, z work groups of the fix-up dispatch
};

uniform ivec2 u_target_size;
uniform ivec2 u_source_size;

bool overflowed() {
    return warp_fixup_count > uint(u_fixup_capacity);
}

void main() {
#if WARP_FIXUP_ARGS
    // one invocation: the work groups for the listed pixels, or for all of them
    uint n = overflowed() ? uint(u_target_size.x * u_target_size.y) : warp_fixup_count;
    warp_fixup_groups = dispatch_groups(n);
#else
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
#endif
}
