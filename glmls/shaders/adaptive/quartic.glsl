// The prediction of a split cell's four children (glmls.imaging.adaptive.patch.predict_cells,
// whose float64 numpy version is the reference). The quartic (tensor-product Lagrange)
// through the cell's 5 x 5 grid of f gives f's values at the children's 5 x 5 grids (the
// cell's 9 x 9 grid in eighths of its sides); each child is then tested on them as on f
// (adaptive/grid.glsl). Where f is smooth over the cell, the quartic errs by f's fifth
// derivatives, two orders below the children's quadratic patches: the prediction of their
// miss is close, and the host accepts a child on it only with a margin
// (glmls.imaging.adaptive), never next to a handle, where f is not smooth. A child's nodes
// are the cell's grid points themselves (the quartic's weights at even eighths are 0 and 1).

// The quartic Lagrange basis of the nodes at 0, 1, 2, 3, 4 (quarters) at the eighths
// e / 2, e = 0 .. 8: row e, 5 weights (dyadic: exact in float32).
const float QUARTIC[45] = float[45](
    1.0, 0.0, 0.0, 0.0, 0.0,
    35.0 / 128.0, 35.0 / 32.0, -35.0 / 64.0, 7.0 / 32.0, -5.0 / 128.0,
    0.0, 1.0, 0.0, 0.0, 0.0,
    -5.0 / 128.0, 15.0 / 32.0, 45.0 / 64.0, -5.0 / 32.0, 3.0 / 128.0,
    0.0, 0.0, 1.0, 0.0, 0.0,
    3.0 / 128.0, -5.0 / 32.0, 45.0 / 64.0, 15.0 / 32.0, -5.0 / 128.0,
    0.0, 0.0, 0.0, 1.0, 0.0,
    -5.0 / 128.0, 7.0 / 32.0, -35.0 / 64.0, 35.0 / 32.0, 35.0 / 128.0,
    0.0, 0.0, 0.0, 0.0, 1.0);

// The children's tests, as adaptive_grid_test's with w = 1, to adaptive_test[first ..
// first + 3] (children (0, 0), (0, 1), (1, 0), (1, 1)).
void adaptive_predict_children(vec2 grid[25], vec2 sides, int first) {
    for (int j = 0; j < 2; ++j) {
        // along the rows first: the cell's 5 rows at the 5 columns of children (., j), the
        // same for both rows of children
        vec2 across[25];
        for (int r = 0; r < 5; ++r) {
            for (int c = 0; c < 5; ++c) {
                int w = 5 * (4 * j + c);
                across[5 * r + c] = QUARTIC[w] * grid[5 * r] + QUARTIC[w + 1] * grid[5 * r + 1]
                    + QUARTIC[w + 2] * grid[5 * r + 2] + QUARTIC[w + 3] * grid[5 * r + 3]
                    + QUARTIC[w + 4] * grid[5 * r + 4];
            }
        }
        for (int i = 0; i < 2; ++i) {
            // then down the columns, to the child's 5 rows
            vec2 child[25];
            for (int r = 0; r < 5; ++r) {
                int w = 5 * (4 * i + r);
                for (int c = 0; c < 5; ++c) {
                    child[5 * r + c] = QUARTIC[w] * across[c] + QUARTIC[w + 1] * across[5 + c]
                        + QUARTIC[w + 2] * across[10 + c] + QUARTIC[w + 3] * across[15 + c]
                        + QUARTIC[w + 4] * across[20 + c];
                }
            }
            vec2 centre = child[12];
            for (int k = 0; k < 25; ++k) {
                child[k] -= centre;
            }
            vec4 test = adaptive_grid_test(child, 0.5 * sides, false);
            adaptive_test[first + 2 * i + j] = vec4(test.xyz, 1.0);
        }
    }
}
