// The adaptive build's cell test (glmls.imaging.adaptive.patch.estimate_cells, whose float64
// numpy version is the reference): one invocation per cell of a level, on f at the cell's
// 5 x 5 grid (adaptive/grid.glsl). Where f is smooth (ADAPTIVE_PREDICT), the
// prediction of the children of the cells that split follows on the GPU, with no round trip
// to the host (glmls.imaging.adaptive.patch.predict_cells, adaptive/quartic.glsl), in
// two passes: ADAPTIVE_PREDICT 1, the test, which lists the cells that fail it (or split
// regardless: flag bit 0 of their record) and have no point handle near (f is not smooth
// there), and sizes the next pass; ADAPTIVE_PREDICT 2, one invocation per listed cell (an
// indirect dispatch of the list's length, not one of all the cells whose listed ones come
// first: llvmpipe gives each of its threads a contiguous share of a dispatch's work groups,
// and the list in the first half left one thread all the work). Not in one pass: lanes run
// together, and a pass that predicted where its cell splits cost the prediction of every
// cell beside one that does (3x the two passes' time on llvmpipe).
//
// Per cell out: its test, vec4 (the miss in output pixels, the smallest singular value, 0
// where the Jacobian's orientation changes over the grid: the cell folds, the largest, 0;
// all 0 for a cell that splits untested);
// with ADAPTIVE_PREDICT then its four children's (0, 0), (0, 1), (1, 0), (1, 1) (row, then
// column), the same with w = 1 where predicted, all 0 where not (no split, or a point
// handle within the reach: f is not smooth there). The host turns them into error bounds;
// it also marks cells with a vertex where f is not finite (no comparison here is trusted
// with NaN: drivers may assume there is none).
layout(local_size_x = LOCAL_SIZE) in;

#include "adaptive/grid.glsl"

#if ADAPTIVE_PREDICT
#include "common/groups.glsl"

layout(std430, binding = BIND_ADAPTIVE_SPLIT) coherent buffer AdaptiveSplit {
    // the prediction pass's work groups, an indirect dispatch's (x, y, z): (0, 0, 1) before
    // the test pass, which raises them as it lists cells (common/groups.glsl's layout)
    uint adaptive_split_groups_x;
    uint adaptive_split_groups_y;
    uint adaptive_split_groups_z;
    uint adaptive_split_count;  // 0 before the test pass
    uint adaptive_split[];      // the cells that split, in no particular order
};
#endif

#if ADAPTIVE_PREDICT == 1
uniform float u_tolerance;      // pixels: a cell whose bound is within it does not split
uniform float u_reach;          // children's sides from the cell's centre: no handle nearer
uniform int u_handles;          // point handles

layout(std430, binding = BIND_ADAPTIVE_HANDLES) readonly buffer AdaptiveHandles {
    vec2 adaptive_handle[];     // the point handles' sources, scaled
};

// Whether no point handle is within ``reach`` (scaled) of ``centre``: one pass over them,
// for the cells that split only (a small part of the evaluations of f they may save).
bool adaptive_far(vec2 centre, float reach) {
    float nearest = 3.0e38;
    for (int k = 0; k < u_handles; ++k) {
        vec2 d = adaptive_handle[k] - centre;
        nearest = min(nearest, dot(d, d));
    }
    return nearest >= reach * reach;
}
#endif

#if ADAPTIVE_PREDICT == 2
#include "adaptive/quartic.glsl"

void main() {
    int listed = int(dispatch_item());
    if (listed >= int(adaptive_split_count)) {
        return;
    }
    int cell = int(adaptive_split[listed]);
    vec2 grid[25];
    vec2 sides;
    adaptive_load_cell(cell, grid, sides);
    adaptive_predict_children(grid, sides, 5 * cell + 1);
}
#else
void main() {
    int cell;
    vec2 grid[25];
    vec2 sides;
    if (!adaptive_load_grid(cell, grid, sides)) {
        return;
    }
    // a cell that splits untested (flag bit 0) gets no test: all 0. A level's cells are
    // all of one kind (the roots, or none), so lanes do not diverge here.
    bool whole = (adaptive_cell(cell, 6).w & 1u) != 0u;   // word 27
    vec4 test = whole ? vec4(0.0) : adaptive_grid_test(grid, sides, true);
#if ADAPTIVE_PREDICT == 1
    adaptive_test[5 * cell] = test;
    for (int k = 1; k <= 4; ++k) {
        adaptive_test[5 * cell + k] = vec4(0.0);
    }
    // the host's bound, SAFETY x miss / smallest (infinite where it folds); in float32, so
    // a cell at the tolerance may go unpredicted: its children are then tested, as safe
    if (!whole && ADAPTIVE_SAFETY * test.x <= u_tolerance * test.y) {
        return;
    }
    // listed only where no handle is near: the prediction pass's lanes all predict
    vec2 centre = uintBitsToFloat(adaptive_cell(cell, 7).xy);   // words 28, 29
    if (adaptive_far(centre, u_reach * 0.5 * max(sides.x, sides.y) / u_scale)) {
        uint k = atomicAdd(adaptive_split_count, 1u);
        adaptive_split[k] = uint(cell);
        // enough groups for the k + 1 listed so far: the largest k sizes the dispatch
        DISPATCH_RAISE(adaptive_split_groups_x, adaptive_split_groups_y, k + 1u)
    }
#else
    adaptive_test[cell] = test;
#endif
}
#endif
