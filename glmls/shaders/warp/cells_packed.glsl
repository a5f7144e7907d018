// The images and buffers of the fused nearest path of the quads (WARP_CELLS_FUSED):
// warp/cells.comp.glsl writes each covered pixel's colour as it scan-converts, and
// warp/cells_fixup.comp.glsl then corrects the pixels where triangles overlap (fold-overs).
// The source and target are the RGBA8 textures themselves, as r32ui images (warp/texels.glsl).
#include "common/groups.glsl"
#include "warp/texels.glsl"

layout(std430, binding = BIND_FIXUPS) buffer WarpFixups {
    uint warp_fixup_count;   // pixels a second triangle reached (may exceed the capacity)
    // the fix-up's work groups, an indirect dispatch's (x, y, z): (0, 0, 1) before the scan,
    // raised by it as it lists pixels (warp_fixup_listed)
    uint warp_fixup_groups_x;
    uint warp_fixup_groups_y;
    uint warp_fixup_groups_z;
    uint warp_fixups[];      // their indices, the first u_fixup_capacity of them
};
uniform int u_fixup_capacity;

// The fix-up dispatch after pixel k of the list (k from atomicAdd on warp_fixup_count) of a
// target of ``pixels``: enough groups for the k + 1 listed, or for every pixel once the list
// overflows (warp/cells_fixup.comp.glsl then redoes them all). The groups change only at
// multiples of LOCAL_SIZE and at the overflow, so only those listings raise them.
void warp_fixup_listed(uint k, uint pixels) {
    uint capacity = uint(u_fixup_capacity);
    if (k % uint(LOCAL_SIZE) == 0u || k == capacity) {
        DISPATCH_RAISE(warp_fixup_groups_x, warp_fixup_groups_y, k < capacity ? k + 1u : pixels)
    }
}

// The embedding test of the fast pass (WARP_CELLS_FAST, warp/cells_check.comp.glsl) and the
// map of where it found folds (warp/cells_hot.glsl).
layout(std430, binding = BIND_CHECK) buffer WarpCheck {
    uint warp_check_bad;         // boundary edges not turning counter-clockwise
    uint warp_check_crossings;   // boundary edges crossing the ray from the centre to +x
    uint warp_check_folded;      // cells not strictly positive
    uint warp_check_redrawn;     // cells the keyed scan redrew (WARP_CELLS_HOT)
    uvec4 warp_check_clear;      // work groups of the winner clear (indirect dispatch)
    uvec4 warp_check_scan;       // work groups of the keyed scan (indirect dispatch)
    uint warp_check_data[];      // the hot tiles and the listed blocks (warp/cells_hot.glsl)
};

// Is the boundary a simple closed curve (one turn about the centre)? Then only pixels near a
// cell not strictly positive can be covered twice (warp/cells_check.comp.glsl).
bool warp_check_boundary_simple() {
    return warp_check_bad == 0u && warp_check_crossings == 1u;
}
