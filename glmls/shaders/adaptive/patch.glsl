// The quadratic patches of the adaptive mesh's leaves (glmls.imaging.adaptive): f through
// each leaf's 3 x 3 nodes (corners, edge mid-points, centre), the interpolant its error test
// bounds, and Newton's method for the source point where a patch reaches a target pixel.

// Per leaf, ADAPTIVE_LEAF vec4s: its box as centre (x, y) and size (width, height) in source
// pixels; f at its centre node (output pixels) and its orientation (+1, -1; 0: it folds); the
// patch in powers of w = (s - centre) / size, w in [-1/2, 1/2]^2 over the leaf: f minus f at
// the centre is sum a_ij wx^i wy^j over i, j <= 2, a_00 = 0, the other eight a_ij in the order
// a_01 a_02 a_10 a_11 a_12 a_20 a_21 a_22, those of f's x in two vec4s, then those of its y
// (glmls.imaging.adaptive.patch.leaf_powers), a table (common/table.glsl). Horner's rule
// then evaluates the patch and its slopes in about a third of the operations of the Lagrange
// form: this runs at every pixel.
#include "common/table.glsl"

layout(binding = BIND_ADAPTIVE_LEAVES) uniform sampler2D adaptive_leaves;
#define ADAPTIVE_LEAF 6
#define NEWTON_STEPS 1

struct LeafPatch {
    vec4 box;
    vec2 centre;
    float orientation;
    vec2 a01, a02, a10, a11, a12, a20, a21, a22;   // the coefficients a_ij of wx^i wy^j (x, y)
};

LeafPatch load_patch(int index) {
    int at = ADAPTIVE_LEAF * index;
    LeafPatch leaf;
    leaf.box = TABLE_FETCH(adaptive_leaves, at);
    vec4 centre = TABLE_FETCH(adaptive_leaves, at + 1);
    leaf.centre = centre.xy;
    leaf.orientation = centre.z;
    vec4 x0 = TABLE_FETCH(adaptive_leaves, at + 2);
    vec4 x1 = TABLE_FETCH(adaptive_leaves, at + 3);
    vec4 y0 = TABLE_FETCH(adaptive_leaves, at + 4);
    vec4 y1 = TABLE_FETCH(adaptive_leaves, at + 5);
    leaf.a01 = vec2(x0.x, y0.x);
    leaf.a02 = vec2(x0.y, y0.y);
    leaf.a10 = vec2(x0.z, y0.z);
    leaf.a11 = vec2(x0.w, y0.w);
    leaf.a12 = vec2(x1.x, y1.x);
    leaf.a20 = vec2(x1.y, y1.y);
    leaf.a21 = vec2(x1.z, y1.z);
    leaf.a22 = vec2(x1.w, y1.w);
    return leaf;
}

// Where the patch maps to x (output pixels, the frame's), from the guess w0 (the leaf's
// centred coordinates, see above), in source pixels: Newton's method, on the guess's side of
// a fold. A step where the patch turns over, and a point that runs off the patch, keep the
// guess: off is more than 1.5 sides past the leaf's edges, half a side where the leaf folds.
// (A pixel near a leaf's edge may lie on its fan but past its patch's curved edge: the
// patch's own inverse there is in the neighbour, and on a 1/4 px leaf 0.7 of a side away,
// where the fan's guess erred by 4.4x the tolerance.) Branch-free: this runs at every pixel,
// and llvmpipe runs both sides of a branch its lanes disagree on anyway.
vec2 patch_inverse(LeafPatch leaf, vec2 x, vec2 w0) {
    float orientation = leaf.orientation;
    vec2 target = x - leaf.centre;
    vec2 w = w0;
    bool ok = true;
    for (int i = 0; i < NEWTON_STEPS; ++i) {
        // r_i(wy) = sum_j a_ij wy^j and its slope q_i, then the sums over wx^i
        float v = w.y;
        float v2 = 2.0 * v;
        vec2 r0 = v * (leaf.a01 + v * leaf.a02);
        vec2 r1 = leaf.a10 + v * (leaf.a11 + v * leaf.a12);
        vec2 r2 = leaf.a20 + v * (leaf.a21 + v * leaf.a22);
        vec2 q0 = leaf.a01 + v2 * leaf.a02;
        vec2 q1 = leaf.a11 + v2 * leaf.a12;
        vec2 q2 = leaf.a21 + v2 * leaf.a22;
        float u = w.x;
        vec2 value = r0 + u * (r1 + u * r2);
        vec2 d_du = r1 + (2.0 * u) * r2;
        vec2 d_dv = q0 + u * (q1 + u * q2);
        float det = d_du.x * d_dv.y - d_dv.x * d_du.y;
        orientation = orientation == 0.0 ? sign(det) : orientation;
        ok = ok && det * orientation > 0.0;
        vec2 miss = value - target;
        vec2 delta = vec2(d_dv.y * miss.x - d_dv.x * miss.y, d_du.x * miss.y - d_du.y * miss.x);
        w = ok ? w - delta / det : w;
    }
    ok = ok && all(lessThanEqual(abs(w), vec2(leaf.orientation == 0.0 ? 1.0 : 2.0)));
    return leaf.box.xy + (ok ? w : w0) * leaf.box.zw;
}
