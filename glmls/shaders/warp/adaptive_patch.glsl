// The quadratic patches of the adaptive mesh's leaves (glmls.imaging.adaptive): f through
// each leaf's 3 x 3 nodes (corners, edge mid-points, centre), the interpolant its error test
// bounds, and Newton's method for the source point where a patch reaches a target pixel.

// Per leaf, ADAPTIVE_LEAF vec4s: its box (x0, y0, width, height) in source pixels; f at its
// centre node (output pixels) and its orientation (+1, -1; 0: it folds); the nine nodes' f
// minus the centre's, row by row, two per vec4.
layout(std430, binding = BIND_ADAPTIVE_LEAVES) readonly buffer AdaptiveLeaves {
    vec4 adaptive_leaf[];
};
#define ADAPTIVE_LEAF 7
#define NEWTON_STEPS 1

struct LeafPatch {
    vec4 box;
    vec2 centre;
    float orientation;
    vec2 n[10];   // the nodes' f minus the centre's (the tenth unused)
};

LeafPatch load_patch(int index) {
    int at = ADAPTIVE_LEAF * index;
    LeafPatch leaf;
    leaf.box = adaptive_leaf[at];
    vec4 centre = adaptive_leaf[at + 1];
    leaf.centre = centre.xy;
    leaf.orientation = centre.z;
    for (int k = 0; k < 5; ++k) {
        vec4 pair = adaptive_leaf[at + 2 + k];
        leaf.n[2 * k] = pair.xy;
        leaf.n[2 * k + 1] = pair.zw;
    }
    return leaf;
}

// The Lagrange basis of the nodes at 0, 1/2 and 1, at t; and its derivative.
vec3 patch_basis(float t) {
    return vec3(2.0 * (t - 0.5) * (t - 1.0), -4.0 * t * (t - 1.0), 2.0 * t * (t - 0.5));
}
vec3 patch_slope(float t) {
    return vec3(4.0 * t - 3.0, 4.0 - 8.0 * t, 4.0 * t - 1.0);
}

// Where the patch maps to x (output pixels, the frame's), from the guess s0 (source pixels):
// Newton's method, on the guess's side of a fold. A step where the patch turns over and a
// point that runs off the patch keep the guess.
vec2 patch_inverse(LeafPatch leaf, vec2 x, vec2 s0) {
    float orientation = leaf.orientation;
    vec2 target = x - leaf.centre;
    vec2 uv = (s0 - leaf.box.xy) / leaf.box.zw;
    for (int i = 0; i < NEWTON_STEPS; ++i) {
        vec3 bu = patch_basis(uv.x);
        vec3 du = patch_slope(uv.x);
        vec3 bv = patch_basis(uv.y);
        vec3 dv = patch_slope(uv.y);
        vec2 value = vec2(0.0);
        vec2 d_du = vec2(0.0);
        vec2 d_dv = vec2(0.0);
        for (int r = 0; r < 3; ++r) {
            vec2 row = bu.x * leaf.n[3 * r] + bu.y * leaf.n[3 * r + 1] + bu.z * leaf.n[3 * r + 2];
            vec2 row_slope =
                du.x * leaf.n[3 * r] + du.y * leaf.n[3 * r + 1] + du.z * leaf.n[3 * r + 2];
            value += bv[r] * row;
            d_du += bv[r] * row_slope;
            d_dv += dv[r] * row;
        }
        float det = d_du.x * d_dv.y - d_dv.x * d_du.y;
        orientation = orientation == 0.0 ? sign(det) : orientation;
        if (!(det * orientation > 0.0)) {
            return s0;
        }
        vec2 miss = value - target;
        uv -= vec2(d_dv.y * miss.x - d_dv.x * miss.y, d_du.x * miss.y - d_du.y * miss.x) / det;
    }
    if (any(greaterThan(abs(uv - 0.5), vec2(1.0)))) {
        return s0;
    }
    return leaf.box.xy + uv * leaf.box.zw;
}
