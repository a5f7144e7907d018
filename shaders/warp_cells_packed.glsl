// The buffers of the fused nearest path of the quads (WARP_CELLS_FUSED): warp_cells.comp.glsl
// writes each covered pixel's colour as it scan-converts, and warp_cells_fixup.comp.glsl then
// corrects the pixels where triangles overlap (fold-overs). Texels are packed RGBA8, one
// uint32 each: storage buffer accesses go lane by lane on llvmpipe, and texel fetches or
// fragment outputs convert each channel besides (about twice the cost there).
layout(std430, binding = 5) readonly buffer WarpSource {
    uint warp_source[];   // the source image, row-major
};
layout(std430, binding = 6) buffer WarpTarget {
    uint warp_target[];   // the target texture's texels (its background on entry), row-major
};
layout(std430, binding = 7) buffer WarpFixups {
    uint warp_fixup_count;   // pixels a second triangle reached (may exceed the capacity)
    uint warp_fixup_pad[3];
    uint warp_fixups[];      // their indices, the first u_fixup_capacity of them
};
uniform int u_fixup_capacity;

// The embedding test of the fast pass (WARP_CELLS_FAST, warp_cells_check.comp.glsl).
layout(std430, binding = 9) buffer WarpCheck {
    uint warp_check_bad;         // cells not strictly positive, boundary edges not turning
    uint warp_check_crossings;   // boundary edges crossing the ray from the centre to +x
    uint warp_check_pad[2];
    uvec4 warp_check_clear;      // work groups of the winner clear (indirect dispatch)
    uvec4 warp_check_scan;       // work groups of the keyed scan (indirect dispatch)
};

// Work groups (of 64) for a 1-D count of items in an indirect dispatch: rows of at most
// WARP_GROUPS_X groups (warp_item() below numbers the invocations row after row).
#define WARP_GROUPS_X 32768u

uvec4 warp_groups(uint items) {
    uint g = (items + 63u) / 64u;
    return uvec4(min(g, WARP_GROUPS_X), (g + WARP_GROUPS_X - 1u) / WARP_GROUPS_X, 1u, 0u);
}

// This invocation's item in such a dispatch (or in a 1-D one) of 64-wide work groups.
uint warp_item() {
    return (gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) * 64u +
           gl_LocalInvocationID.x;
}
