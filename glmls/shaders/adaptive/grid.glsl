// The adaptive build's test of one cell from its 5 x 5 grid (quarters of its sides), shared by
// the cells' test (adaptive/test.comp.glsl: f at the grid) and the children's prediction
// (adaptive/quartic.glsl: the parent's quartic at the children's grids).
// glmls.imaging.adaptive.patch.estimate_cells is the float64 reference.
//
// The grid holds the quadratic patch's 3 x 3 nodes (even row and column) and 16 test points.
// The patch (Lagrange, through the nodes) is evaluated at every grid point, with its slopes:
// its miss is the largest distance between it and the grid's values at the test points (and,
// in the cells' test, the quartic through those misses on lines near the cell's edges), and
// its Jacobian's singular values on the 25 points give the smallest and the largest stretch.
// The values are f - v (scaled) less the centre node's: the patch reproduces v and constants,
// so its miss is the same, and the sums round on the variation over the cell, not on f - v.

uniform float u_scale;    // pixels per scaled unit

// The quadratic Lagrange basis of the nodes at 0, 1/2, 1 at t = 0, 1/4, 1/2, 3/4, 1, and its
// slopes (per unit of t).
const vec3 BASIS[5] = vec3[5](vec3(1.0, 0.0, 0.0), vec3(0.375, 0.75, -0.125),
                              vec3(0.0, 1.0, 0.0), vec3(-0.125, 0.75, 0.375),
                              vec3(0.0, 0.0, 1.0));
const vec3 SLOPE[5] = vec3[5](vec3(-3.0, 4.0, -1.0), vec3(-2.0, 2.0, 0.0), vec3(-1.0, 0.0, 1.0),
                              vec3(0.0, -2.0, 2.0), vec3(1.0, -4.0, 3.0));

vec2 combine(vec3 weights, vec2 a, vec2 b, vec2 c) {
    return weights.x * a + weights.y * b + weights.z * c;
}

// The quartic through 5 values at the quarters (nodes 0 .. 4) at u = 0.15 of the way: its
// Lagrange weights (reversed, at 0.85).
const float INSET[5] = float[5](119.0 / 625.0, 714.0 / 625.0, -306.0 / 625.0, 119.0 / 625.0,
                                -21.0 / 625.0);

// That quartic at 0.15 (``mirrored`` false) or 0.85 (true).
vec2 quartic_at_inset(bool mirrored, vec2 v0, vec2 v1, vec2 v2, vec2 v3, vec2 v4) {
    return mirrored
        ? INSET[4] * v0 + INSET[3] * v1 + INSET[2] * v2 + INSET[1] * v3 + INSET[0] * v4
        : INSET[0] * v0 + INSET[1] * v1 + INSET[2] * v2 + INSET[3] * v3 + INSET[4] * v4;
}

// The largest square of the quartic through the 5 x 5 misses ``m`` (0 at the nodes) on the
// lines 0.15 of a side in from the cell's edges (the 24 points of them off the 5 x 5 grid;
// glmls.imaging.adaptive.patch.MEASURED): a quadratic patch's error of f's third and fourth
// orders peaks between the quarters and the edges, up to 4/3 above its values at the
// quarters along a line, and this finds at least 95 % of its peak along a line, 90 % over
// the cell (the quarters alone: 3/4 and 70 %). Only the nonzero terms: a node column's
// (row's) misses are 0 on the node rows (columns).
float adaptive_inset_miss2(vec2 m[25]) {
    float most = 0.0;
    for (int k = 0; k < 2; ++k) {
        // column 0.15 or 0.85: on the 5 rows of the grid, then on rows 0.15 and 0.85
        bool mirrored = k == 1;
        vec2 col[5];
        for (int r = 0; r < 5; r += 2) {
            col[r] = quartic_at_inset(mirrored, vec2(0.0), m[5 * r + 1], vec2(0.0),
                                      m[5 * r + 3], vec2(0.0));
        }
        for (int r = 1; r < 5; r += 2) {
            col[r] = quartic_at_inset(mirrored, m[5 * r], m[5 * r + 1], m[5 * r + 2],
                                      m[5 * r + 3], m[5 * r + 4]);
        }
        for (int r = 0; r < 5; ++r) {
            most = max(most, dot(col[r], col[r]));
        }
        for (int o = 0; o < 2; ++o) {
            vec2 v = quartic_at_inset(o == 1, col[0], col[1], col[2], col[3], col[4]);
            most = max(most, dot(v, v));
        }
    }
    for (int c = 0; c < 5; ++c) {
        // rows 0.15 and 0.85 on the 5 columns of the grid
        bool node = (c & 1) == 0;   // 0 on the node rows
        for (int o = 0; o < 2; ++o) {
            vec2 v = quartic_at_inset(o == 1, node ? vec2(0.0) : m[c], m[5 + c],
                                      node ? vec2(0.0) : m[10 + c], m[15 + c],
                                      node ? vec2(0.0) : m[20 + c]);
            most = max(most, dot(v, v));
        }
    }
    return most;
}

// ``grid``: the 25 values row by row (grid[12], the centre, is 0); ``sides``: the cell's width
// and height in pixels. Out: the miss (output pixels), the smallest singular value (0 where
// the Jacobian's orientation changes over the grid: the cell folds), the largest, 0. With
// ``inset`` the miss is also the largest of the quartic through the patch's misses
// (adaptive_inset_miss2): the patch's error peaks between the quarter points (a quartic
// error 4/3 above its value there). The children's prediction goes without: its margin
// covers it, and it runs four tests per cell.
vec4 adaptive_grid_test(vec2 grid[25], vec2 sides, bool inset) {
    vec2 scale = u_scale / sides;
    float miss2 = 0.0;
    vec2 misses[25];
    float low = 3.0e38;    // the smallest singular value's square
    float high = 0.0;      // the largest's
    bool positive = true;
    bool negative = true;
    for (int r = 0; r < 5; ++r) {
        // down to row r, for each column of nodes: the patch's column and its slope
        vec3 basis = BASIS[r];
        vec3 slope = SLOPE[r];
        vec2 col0 = combine(basis, grid[0], grid[10], grid[20]);
        vec2 col1 = combine(basis, grid[2], grid[12], grid[22]);
        vec2 col2 = combine(basis, grid[4], grid[14], grid[24]);
        vec2 col0_slope = combine(slope, grid[0], grid[10], grid[20]);
        vec2 col1_slope = combine(slope, grid[2], grid[12], grid[22]);
        vec2 col2_slope = combine(slope, grid[4], grid[14], grid[24]);
        for (int c = 0; c < 5; ++c) {
            vec2 value = combine(BASIS[c], col0, col1, col2);
            vec2 du = combine(SLOPE[c], col0, col1, col2);
            vec2 dv = combine(BASIS[c], col0_slope, col1_slope, col2_slope);
            // at the nodes the patch is the value itself: a miss of 0
            vec2 miss = value - grid[5 * r + c];
            misses[5 * r + c] = miss;
            miss2 = max(miss2, dot(miss, miss));
            // f's Jacobian per pixel, f = v + scale (f - v)
            float ja = 1.0 + scale.x * du.x;
            float jb = scale.y * dv.x;
            float jc = scale.x * du.y;
            float jd = 1.0 + scale.y * dv.y;
            float det = ja * jd - jb * jc;
            float frob = ja * ja + jb * jb + jc * jc + jd * jd;
            // s_max^2 from the larger root; s_min^2 = det^2 / s_max^2 (no cancellation)
            float top = 0.5 * (frob + sqrt(max(frob * frob - 4.0 * det * det, 0.0)));
            high = max(high, top);
            low = min(low, top > 0.0 ? det * det / top : 0.0);
            positive = positive && det > 0.0;
            negative = negative && det < 0.0;
        }
    }
    if (inset) {
        miss2 = max(miss2, adaptive_inset_miss2(misses));
    }
    float smallest = (positive || negative) ? sqrt(low) : 0.0;
    return vec4(u_scale * sqrt(miss2), smallest, sqrt(high), 0.0);
}

#include "common/table.glsl"

// tables (common/table.glsl)
layout(binding = BIND_ADAPTIVE_F) uniform sampler2D adaptive_f;
                             // per vertex evaluated so far, by id: f - v, scaled (RG)
layout(binding = BIND_ADAPTIVE_CELLS) uniform usampler2D adaptive_cells;
                             // per cell, CELL_WORDS / 4 texels: 9 node ids (row by row), the
                             // 16 test points' ids (row by row), width and height (float
                             // bits), flags (bit 0: it splits untested), its centre (scaled,
                             // float bits)

layout(std430, binding = BIND_ADAPTIVE_TESTS) writeonly buffer AdaptiveTests {
    vec4 adaptive_test[];    // per cell, what the pass writes (one or five vec4)
};

uniform int u_count;      // cells
uniform int u_offset;     // first cell of this dispatch

#ifndef CELL_WORDS
#error "CELL_WORDS: the host's layout (glmls.imaging.adaptive.cells) defines it"
#endif

// The grid place (row by row) of each id of a cell's record: the nodes, then the tests.
const int GRID_PLACE[25] = int[25](0, 2, 4, 10, 12, 14, 20, 22, 24,
                                   1, 3, 5, 6, 7, 8, 9, 11, 13, 15, 16, 17, 18, 19, 21, 23);

// Texel k (words 4 k .. 4 k + 3) of cell ``cell``'s record.
uvec4 adaptive_cell(int cell, int k) {
    return TABLE_FETCH(adaptive_cells, (CELL_WORDS / 4) * cell + k);
}

// Cell ``cell``'s 25 values less its centre node's, and its sides (pixels).
void adaptive_load_cell(int cell, out vec2 grid[25], out vec2 sides) {
    uvec4 record[7];   // words 0 .. 27
    for (int k = 0; k < 7; ++k) {
        record[k] = adaptive_cell(cell, k);
    }
    vec2 centre = TABLE_FETCH(adaptive_f, record[1].x).xy;   // word 4
    for (int k = 0; k < 25; ++k) {
        grid[GRID_PLACE[k]] = TABLE_FETCH(adaptive_f, record[k >> 2][k & 3]).xy - centre;
    }
    sides = uintBitsToFloat(record[6].yz);   // words 25, 26
}

// This invocation's cell (false past the last: nothing to do), as adaptive_load_cell.
bool adaptive_load_grid(out int cell, out vec2 grid[25], out vec2 sides) {
    cell = u_offset + int(gl_GlobalInvocationID.x);
    if (cell >= u_count) {
        return false;
    }
    adaptive_load_cell(cell, grid, sides);
    return true;
}
