// The adaptive build's cell test (glmls.imaging.adaptive_patch.estimate_cells, whose float64
// numpy version is the reference): one invocation per cell of a level, on f at the cell's
// 5 x 5 grid (warp/adaptive_grid.glsl).
//
// Per cell out, vec4: the miss (output pixels), the smallest singular value (0 where the
// Jacobian's orientation changes over the grid: the cell folds), the largest, 0. The host
// turns them into the error bound; it also marks cells with a vertex where f is not finite
// (no comparison here is trusted with NaN: drivers may assume there is none).
layout(local_size_x = LOCAL_SIZE) in;

#include "warp/adaptive_grid.glsl"

void main() {
    int cell;
    vec2 grid[25];
    vec2 sides;
    if (!adaptive_load_grid(cell, grid, sides)) {
        return;
    }
    adaptive_test[cell] = adaptive_grid_test(grid, sides);
}
