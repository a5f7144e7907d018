// The adaptive build's cell test (glmls.imaging.adaptive_patch.estimate_cells, whose float64 numpy
// version is the reference): one invocation per cell of a level.
//
// A cell's 5 x 5 grid (quarters of its sides) holds its quadratic patch's 3 x 3 nodes (even
// row and column) and 16 test points. The patch (Lagrange, through the nodes) is evaluated at
// every grid point, with its slopes: its miss is the largest distance between it and f at the
// test points, and its Jacobian's singular values on the 25 points give the smallest and the
// largest stretch. The patch is built from f - v (what mls/points.comp.glsl wrote, scaled):
// it reproduces v exactly, so its miss is the same, and the displacements keep float32's
// digits where f itself (up to the image's size) would lose them.
//
// Per cell out, vec4: the miss (output pixels), the smallest singular value (0 where the
// Jacobian's orientation changes over the grid: the cell folds), the largest, 0. The host
// turns them into the error bound; it also marks cells with a vertex where f is not finite
// (no comparison here is trusted with NaN: drivers may assume there is none).
layout(local_size_x = LOCAL_SIZE) in;

layout(std430, binding = BIND_ADAPTIVE_F) readonly buffer AdaptiveF {
    vec2 adaptive_f[];       // f - v at every vertex evaluated so far, scaled, by vertex id
};
layout(std430, binding = BIND_ADAPTIVE_CELLS) readonly buffer AdaptiveCells {
    uint adaptive_cell[];    // per cell, CELL_WORDS: 9 node ids (row by row), the 16 test
                             // points' ids (row by row), width and height (float bits)
};
layout(std430, binding = BIND_ADAPTIVE_TESTS) writeonly buffer AdaptiveTests {
    vec4 adaptive_test[];
};

#ifndef CELL_WORDS
#error "CELL_WORDS: the host's layout (glmls.imaging.adaptive_cells) defines it"
#endif

uniform int u_count;      // cells
uniform int u_offset;     // first cell of this dispatch
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

void main() {
    int cell = u_offset + int(gl_GlobalInvocationID.x);
    if (cell >= u_count) {
        return;
    }
    int at = cell * CELL_WORDS;
    // about the centre node: the patch reproduces constants, so the miss is the same, and
    // the sums below then round on the variation over the cell, not on f - v itself
    vec2 centre = adaptive_f[adaptive_cell[at + 4]];
    vec2 n0 = adaptive_f[adaptive_cell[at]] - centre;
    vec2 n1 = adaptive_f[adaptive_cell[at + 1]] - centre;
    vec2 n2 = adaptive_f[adaptive_cell[at + 2]] - centre;
    vec2 n3 = adaptive_f[adaptive_cell[at + 3]] - centre;
    vec2 n5 = adaptive_f[adaptive_cell[at + 5]] - centre;
    vec2 n6 = adaptive_f[adaptive_cell[at + 6]] - centre;
    vec2 n7 = adaptive_f[adaptive_cell[at + 7]] - centre;
    vec2 n8 = adaptive_f[adaptive_cell[at + 8]] - centre;
    vec2 n4 = vec2(0.0);
    vec2 scale = u_scale / vec2(uintBitsToFloat(adaptive_cell[at + 25]),
                                uintBitsToFloat(adaptive_cell[at + 26]));
    float miss2 = 0.0;
    float low = 3.0e38;    // the smallest singular value's square
    float high = 0.0;      // the largest's
    bool positive = true;
    bool negative = true;
    int test = at + 9;     // the next test point's id (they are stored row by row)
    for (int r = 0; r < 5; ++r) {
        // down to row r, for each column of nodes: the patch's column and its slope
        vec3 basis = BASIS[r];
        vec3 slope = SLOPE[r];
        vec2 col0 = combine(basis, n0, n3, n6);
        vec2 col1 = combine(basis, n1, n4, n7);
        vec2 col2 = combine(basis, n2, n5, n8);
        vec2 col0_slope = combine(slope, n0, n3, n6);
        vec2 col1_slope = combine(slope, n1, n4, n7);
        vec2 col2_slope = combine(slope, n2, n5, n8);
        for (int c = 0; c < 5; ++c) {
            vec2 value = combine(BASIS[c], col0, col1, col2);
            vec2 du = combine(SLOPE[c], col0, col1, col2);
            vec2 dv = combine(BASIS[c], col0_slope, col1_slope, col2_slope);
            if (r % 2 == 1 || c % 2 == 1) {
                vec2 miss = value - (adaptive_f[adaptive_cell[test]] - centre);
                miss2 = max(miss2, dot(miss, miss));
                ++test;
            }
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
    float smallest = (positive || negative) ? sqrt(low) : 0.0;
    adaptive_test[cell] = vec4(u_scale * sqrt(miss2), smallest, sqrt(high), 0.0);
}
