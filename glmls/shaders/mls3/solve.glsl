// The 3D closed forms of MLS from the weighted moments about p* and q* (docs/mathematics.md,
// "In three dimensions" and "The 3D solve on the GPU"): the plain branch, in float32, where
// the handles in reach spread in all three directions about the point:
//
//   A = sum w p^T p^ (symmetric), D = sum w p^T e^ with e = q - p, B = A + D;
//   rigid: B's orthogonal polar factor R (det B > 0: Kabsch's solution needs no reflection
//          fix); similarity: R times Umeyama's scale trace(R^T B) / trace(A);
//   affine: A^-1 B, by Cholesky.
//
// Every other point (a degenerate handle set's ridges, Horn's rotation where B is near
// singular or reflects) is left with N = 0 and mls3_solve_later set: its caller solves it
// again in float64 from moments summed in float64 (mls3/solve_full.glsl, mls3/core.glsl's
// mls3_finish), or, in a pass compiled with MLS3_SOLVE_LATER 1, lists it for a second pass
// over those points alone (a GPU's warp, and a CPU renderer's vector whatever its lanes'
// mask, runs a branch for all its lanes where one takes it; the rare branches are most of the
// solve's code).
//
// Matrices are GLSL mat3 used as ``v * M`` (row vectors): the mathematical M[i][j] is the
// GLSL M[j][i], so outerProduct(P, E) is sum P^T E and matrix products agree. Everything is
// returned as N = M - I, exactly 0 where the displacements in reach are all equal (D = 0).
//
// Defines: MLS_TRANSFORM (0 affine, 1 similarity, 2 rigid); MLS3_SOLVE_LATER (see above).
#ifndef MLS3_SOLVE_LATER
#define MLS3_SOLVE_LATER 0
#endif
bool mls3_solve_later = false;
// Whether the last solve was affine's plain N = A^-1 D (Cholesky here, or mls3_solve_full
// without a ridge), M = A^-1 B: with every target on one plane (normal n), B n = 0, so M n = 0
// and f maps into that plane (mls3/core.glsl's mls3_jacobian_plain); false for every other
// branch (a ridge, a translation, the identity).
bool mls3_solve_plain = false;
// The rotations' last solve: B's orthogonal polar factor where it took that branch (or
// mls3_solve_full found it, no ridge), else 0 (mls3_finish resets it; mls3_eval_jacobian
// differentiates it).
mat3 mls3_solve_polar = mat3(0.0);

// glmls.reference.DEGENERATE_SHARE
const float MLS3_DEGENERATE_SHARE = 1e-3;
// affine's plain branch: every eigenvalue of A above this share of its trace. A's condition
// (up to 1 / share) magnifies the float32 moments' rounding in A^-1 D: at 1e-3, the ridge's
// onset, that moved f by up to 1e-2 voxel 100 voxels from p*; the float64 solve takes the
// points below 1e-2 (few: where three or four handles near a plane are all in reach).
const float MLS3_PLAIN_AFFINE = 1e-2;
// Newton's iteration for the orthogonal polar factor of B (det B > 0): X <- (g X + X^-T / g)
// / 2 with Higham's scaling g = (|X^-1| / |X|)^(1/2) (Frobenius norms), quadratic from the
// start; stops once a step changes X by less than float32 resolves.
const float MLS3_POLAR_DET = 0.01;   // det B / |B|^3 above which Newton takes <= 8 steps
const int MLS3_POLAR_STEPS = 10;

mat3 mls3_polar(mat3 B) {
    mat3 X = B;
    for (int k = 0; k < MLS3_POLAR_STEPS; ++k) {
        mat3 Y = transpose(inverse(X));
        float nx = dot(X[0], X[0]) + dot(X[1], X[1]) + dot(X[2], X[2]);
        float ny = dot(Y[0], Y[0]) + dot(Y[1], Y[1]) + dot(Y[2], Y[2]);
        float g = sqrt(sqrt(ny / nx));
        mat3 next = 0.5 * (g * X + Y / g);
        mat3 change = next - X;
        X = next;
        float c = dot(change[0], change[0]) + dot(change[1], change[1])
                + dot(change[2], change[2]);
        if (c < 1e-13) {
            break;
        }
    }
    return X;
}

// The mathematical [n]x, with [n]x u = n x u for a column vector u: rows (0, -nz, ny),
// (nz, 0, -nx), (-ny, nx, 0), built from its columns as every GLSL matrix.
mat3 mls3_cross_matrix(vec3 n) {
    return mat3(vec3(0.0, n.z, -n.y), vec3(-n.z, 0.0, n.x), vec3(n.y, -n.x, 0.0));
}

// A^-1 d for the symmetric positive definite A = L L^T (Cholesky factor columns l0, l1, l2,
// lower triangular: l0 = (L00, L10, L20), l1 = (0, L11, L21), l2 = (0, 0, L22)).
vec3 mls3_cholesky_apply(vec3 l0, vec3 l1, vec3 l2, vec3 d) {
    float y0 = d.x / l0.x;
    float y1 = (d.y - l0.y * y0) / l1.y;
    float y2 = (d.z - l0.z * y0 - l1.z * y1) / l2.z;
    float x2 = y2 / l2.z;
    float x1 = (y1 - l1.z * x2) / l1.y;
    float x0 = (y0 - l0.y * x1 - l0.z * x2) / l0.x;
    return vec3(x0, x1, x2);
}

// Targets near one line: whether B B^T's middle eigenvalue may be below 1e-3 of its trace
// (its invariants say so).
bool mls3_targets_on_a_line(mat3 B) {
    mat3 BBt = B * transpose(B);
    vec3 bd = vec3(BBt[0][0], BBt[1][1], BBt[2][2]);
    vec3 bo = vec3(BBt[1][0], BBt[2][0], BBt[2][1]);
    float btr = bd.x + bd.y + bd.z;
    float bc2 = bd.x * bd.y + bd.x * bd.z + bd.y * bd.z - dot(bo, bo);
    return btr > 0.0 && !(bc2 > 2.0 * MLS3_DEGENERATE_SHARE * btr * btr);
}

// N = M - I from the symmetric A (diagonal a, off-diagonal o = (01, 02, 12)) and D, about
// p* and q*; spread = sum w |p - v|^2 over the handles not at the nearest one's place, the
// yardstick for coincident sources (mls3_add).
//
// Where A's eigenvalues provably keep every ridge at 0 (its invariants bound them: with
// trace 1, det A / c2 <= e_min and c2 < 2 e_mid for e_mid < 1e-3, c2 the sum of A's
// principal 2 x 2 minors), the exact closed forms need neither A's eigenvectors nor (affine)
// the similarity solution: A^-1 D by Cholesky, Horn's rotation of B itself.
mat3 mls3_solve(vec3 a, vec3 o, mat3 D, float spread) {
    float mu = a.x + a.y + a.z;
    // Coincident sources in reach, or one handle (the spread about p* is float32 noise
    // against the yardstick): a translation. All displacements equal
    // (D = 0, the identity among them): N = 0 exactly, as every closed form gives it.
    bool zero = D[0] == vec3(0.0) && D[1] == vec3(0.0) && D[2] == vec3(0.0);
    if (!(mu > 1e-13 * spread) || zero) {
        return mat3(0.0);
    }
    // in units of trace(A): float32 keeps its range whatever the weights' scale
    float inv = 1.0 / mu;
    a *= inv;
    o *= inv;
    D *= inv;
    float tr = a.x + a.y + a.z;   // trace(A) in its own units: 1 but for rounding
    float c2 = a.x * a.y + a.x * a.z + a.y * a.z - dot(o, o);
    float det = a.x * (a.y * a.z - o.z * o.z) - o.x * (o.x * a.z - o.z * o.y)
              + o.y * (o.x * o.z - a.y * o.y);
    // (c2 bounds e_mid away from 0 first, so that rounding cannot pass det / c2 off as e_min)
#if MLS_TRANSFORM == 0
    if (c2 > 2.0 * MLS3_PLAIN_AFFINE * tr * tr && det > MLS3_PLAIN_AFFINE * c2 * tr) {
        // every eigenvalue above 1e-2 trace(A): no ridge, N = A^-1 D
        vec3 l0 = vec3(sqrt(a.x), o.x, o.y);
        l0.yz /= l0.x;
        float l11 = sqrt(a.y - l0.y * l0.y);
        vec3 l1 = vec3(0.0, l11, (o.z - l0.z * l0.y) / l11);
        vec3 l2 = vec3(0.0, 0.0, sqrt(a.z - l0.z * l0.z - l1.z * l1.z));
        if (l2.z > 0.0 && l11 > 0.0) {
            mls3_solve_plain = true;
            return mat3(mls3_cholesky_apply(l0, l1, l2, D[0]),
                        mls3_cholesky_apply(l0, l1, l2, D[1]),
                        mls3_cholesky_apply(l0, l1, l2, D[2]));
        }
    }
#else
    // the middle eigenvalue above 1e-3 trace(A) (no ridge on the rotation), the targets not
    // near one line, and B comfortably nonsingular with det B > 0: B's polar factor
    bool spread3 = c2 > 2.0 * MLS3_DEGENERATE_SHARE * tr * tr;
    mat3 B = mat3(vec3(a.x, o.x, o.y), vec3(o.x, a.y, o.z), vec3(o.y, o.z, a.z)) + D;
    float nb2 = dot(B[0], B[0]) + dot(B[1], B[1]) + dot(B[2], B[2]);
    if (spread3 && !mls3_targets_on_a_line(B)
        && determinant(B) > MLS3_POLAR_DET * nb2 * sqrt(nb2)) {
        mls3_solve_polar = mls3_polar(B);
        mat3 NR = mls3_solve_polar - mat3(1.0);
        // trace(R^T B) - trace(A) = trace(D) + <R - I, B>, without cancellation
        float gain = D[0][0] + D[1][1] + D[2][2]
                   + dot(NR[0], B[0]) + dot(NR[1], B[1]) + dot(NR[2], B[2]);
        float along = tr + gain;   // trace(R^T B)
#if MLS_TRANSFORM == 2
        // all targets in reach collapsed to one point: no rotation is defined, M = I
        return along > 1e-6 * tr ? NR : mat3(0.0);
#else
        // Umeyama's scale: trace(R^T B) / trace(A), minus 1 without cancellation
        return (along / tr) * NR + (gain / tr) * mat3(1.0);
#endif
    }
#endif
    mls3_solve_later = true;
    return mat3(0.0);
}
