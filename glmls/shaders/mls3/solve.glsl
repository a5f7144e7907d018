// The 3D closed forms of MLS from the weighted moments about p* and q* (docs/mathematics.md,
// "In three dimensions" and "The 3D solve on the GPU"), in float32, with the degenerate-case
// rules of glmls.reference (_solve3, _ridge, _least_rotation, _rotation3):
//
//   A = sum w p^T p^ (symmetric), D = sum w p^T e^ with e = q - p, B = A + D;
//   rigid: the rotation R maximising trace(R^T B') (Horn's quaternion: the eigenvector of the
//          largest eigenvalue of a symmetric 4 x 4 matrix, by cyclic Jacobi sweeps), where
//          B' = B + c |B| R0 adds the least rotation R0 of A's principal axis where the
//          sources are near one line (c, the ridge's share of A's middle eigenvalue), and
//          c' |B| R0' likewise of B B^T where the targets are near one line;
//   similarity: R times Umeyama's scale trace(R^T B) / trace(A);
//   affine: (A + g(A))^-1 (B + g(A) M_sim), g(A) the ridge of A's small eigenvalues
//          (A's eigenvalues and vectors by cyclic Jacobi sweeps).
//
// Matrices are GLSL mat3 used as ``v * M`` (row vectors): the mathematical M[i][j] is the
// GLSL M[j][i], so outerProduct(P, E) is sum P^T E and matrix products agree. Everything is
// returned as N = M - I, exactly 0 where the displacements in reach are all equal (D = 0).
//
// Defines: MLS_TRANSFORM (0 affine, 1 similarity, 2 rigid); MLS3_SOLVE_LATER 1: only the
// plain branch (Cholesky for affine, B's polar factor for the rotations), the others leaving
// N = 0 and mls3_solve_later set, for the caller's second pass over those points alone (a
// GPU's warp, and a CPU renderer's vector whatever its lanes' mask, runs a branch for all its
// lanes where one takes it; the rare branches are most of the solve's code).
#ifndef MLS3_SOLVE_LATER
#define MLS3_SOLVE_LATER 0
#endif
bool mls3_solve_later = false;
// The rotations' last solve: B's orthogonal polar factor where it took that branch, else I
// (mls3_eval_jacobian's short solves of the probes start from it).
mat3 mls3_solve_polar = mat3(1.0);

// glmls.reference.DEGENERATE_SHARE
const float MLS3_DEGENERATE_SHARE = 1e-3;
// Cyclic Jacobi sweeps: 3 x 3 (A's eigenvalues) and 4 x 4 (Horn's matrix). Each sweep
// zeroes every off-diagonal element once; convergence is quadratic, and these many leave
// off-diagonal elements below float32's rounding of the diagonal.
const int MLS3_SWEEPS3 = 4;
const int MLS3_SWEEPS4 = 4;

// One Jacobi rotation zeroing apq in a symmetric matrix: app, aqq, apq the (p, q) block, and
// for each other index r the pair (arp, arq); vp, vq the eigenvector columns p and q.
// Branch-free: apq == 0 is no rotation (t = 0).
void mls3_rotation(float app, float aqq, float apq, out float c, out float s, out float t) {
    float theta = (aqq - app) / (2.0 * apq);
    float sg = theta >= 0.0 ? 1.0 : -1.0;
    // theta * theta may overflow: t is then 0, as good as exact for so small an apq
    t = apq == 0.0 ? 0.0 : sg / (abs(theta) + sqrt(theta * theta + 1.0));
    c = inversesqrt(t * t + 1.0);
    s = t * c;
}

void mls3_jacobi3_pq(inout float app, inout float aqq, inout float apq, inout float arp,
                     inout float arq, inout vec3 vp, inout vec3 vq) {
    float c, s, t;
    mls3_rotation(app, aqq, apq, c, s, t);
    app -= t * apq;
    aqq += t * apq;
    apq = 0.0;
    float rp = arp, rq = arq;
    arp = c * rp - s * rq;
    arq = s * rp + c * rq;
    vec3 p = vp, q = vq;
    vp = c * p - s * q;
    vq = s * p + c * q;
}

// Eigen-decomposition of the symmetric A = [[a.x, o.x, o.y], [o.x, a.y, o.z], [o.y, o.z, a.z]]
// (diagonal a, off-diagonal o = (01, 02, 12)): eigenvalues e and unit eigenvectors v0..v2.
void mls3_eigen3(vec3 a, vec3 o, out vec3 e, out vec3 v0, out vec3 v1, out vec3 v2) {
    float a00 = a.x, a11 = a.y, a22 = a.z, a01 = o.x, a02 = o.y, a12 = o.z;
    v0 = vec3(1.0, 0.0, 0.0);
    v1 = vec3(0.0, 1.0, 0.0);
    v2 = vec3(0.0, 0.0, 1.0);
    for (int k = 0; k < MLS3_SWEEPS3; ++k) {
        mls3_jacobi3_pq(a00, a11, a01, a02, a12, v0, v1);   // (0, 1), r = 2
        mls3_jacobi3_pq(a00, a22, a02, a01, a12, v0, v2);   // (0, 2), r = 1
        mls3_jacobi3_pq(a11, a22, a12, a01, a02, v1, v2);   // (1, 2), r = 0
    }
    e = vec3(a00, a11, a22);
}

void mls3_jacobi4_pq(inout float app, inout float aqq, inout float apq, inout float arp,
                     inout float arq, inout float asp, inout float asq, inout vec4 vp,
                     inout vec4 vq) {
    float c, s, t;
    mls3_rotation(app, aqq, apq, c, s, t);
    app -= t * apq;
    aqq += t * apq;
    apq = 0.0;
    float rp = arp, rq = arq, sp = asp, sq = asq;
    arp = c * rp - s * rq;
    arq = s * rp + c * rq;
    asp = c * sp - s * sq;
    asq = s * sp + c * sq;
    vec4 p = vp, q = vq;
    vp = c * p - s * q;
    vq = s * p + c * q;
}

// The unit quaternion (w, x, y, z) of the rotation Rc (column vectors) maximising
// sum w q^ . (Rc p^) for S = sum w p^T q^ (Horn 1987), i.e. R = Rc^T maximising
// trace(R^T S): the eigenvector of the largest eigenvalue of Horn's symmetric 4 x 4 matrix.
// S = A + S2 with A symmetric (diagonal a, off-diagonal o = (01, 02, 12)): the antisymmetric
// parts come from S2 alone, without the rounding of A + S2.
vec4 mls3_horn(vec3 a, vec3 o, mat3 S2) {
    // S2[i][j] in GLSL is the mathematical S2_ji (see above)
    float sxx = S2[0][0], syy = S2[1][1], szz = S2[2][2];
    float sxy = S2[1][0], syx = S2[0][1], sxz = S2[2][0], szx = S2[0][2];
    float syz = S2[2][1], szy = S2[1][2];
    float a00 = (a.x + a.y + a.z) + (sxx + syy + szz);
    float a11 = (a.x - a.y - a.z) + (sxx - syy - szz);
    float a22 = (a.y - a.x - a.z) + (syy - sxx - szz);
    float a33 = (a.z - a.x - a.y) + (szz - sxx - syy);
    float a01 = syz - szy, a02 = szx - sxz, a03 = sxy - syx;
    float a12 = 2.0 * o.x + (sxy + syx), a13 = 2.0 * o.y + (szx + sxz);
    float a23 = 2.0 * o.z + (syz + szy);
    vec4 v0 = vec4(1.0, 0.0, 0.0, 0.0);
    vec4 v1 = vec4(0.0, 1.0, 0.0, 0.0);
    vec4 v2 = vec4(0.0, 0.0, 1.0, 0.0);
    vec4 v3 = vec4(0.0, 0.0, 0.0, 1.0);
    for (int k = 0; k < MLS3_SWEEPS4; ++k) {
        mls3_jacobi4_pq(a00, a11, a01, a02, a12, a03, a13, v0, v1);   // (0, 1), r, s = 2, 3
        mls3_jacobi4_pq(a00, a22, a02, a01, a12, a03, a23, v0, v2);   // (0, 2), r, s = 1, 3
        mls3_jacobi4_pq(a00, a33, a03, a01, a13, a02, a23, v0, v3);   // (0, 3), r, s = 1, 2
        mls3_jacobi4_pq(a11, a22, a12, a01, a02, a13, a23, v1, v2);   // (1, 2), r, s = 0, 3
        mls3_jacobi4_pq(a11, a33, a13, a01, a03, a12, a23, v1, v3);   // (1, 3), r, s = 0, 2
        mls3_jacobi4_pq(a22, a33, a23, a02, a03, a12, a13, v2, v3);   // (2, 3), r, s = 0, 1
    }
    // the largest eigenvalue's vector (the first of equals: the identity's where S = 0)
    vec4 q = v0;
    float best = a00;
    q = a11 > best ? v1 : q;
    best = max(best, a11);
    q = a22 > best ? v2 : q;
    best = max(best, a22);
    q = a33 > best ? v3 : q;
    return normalize(q);
}

// R - I (row vectors: R = Rc^T) of the unit quaternion q = (w, x, y, z), without cancellation
// for small rotations and exactly 0 for (+-1, 0, 0, 0).
mat3 mls3_quaternion_minus_identity(vec4 q) {
    float w = q.x, x = q.y, y = q.z, z = q.w;
    // the rows of Rc - I are the columns of R - I, which a GLSL matrix is built from
    return mat3(vec3(-2.0 * (y * y + z * z), 2.0 * (x * y - w * z), 2.0 * (x * z + w * y)),
                vec3(2.0 * (x * y + w * z), -2.0 * (x * x + z * z), 2.0 * (y * z - w * x)),
                vec3(2.0 * (x * z - w * y), 2.0 * (y * z + w * x), -2.0 * (x * x + y * y)));
}

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

// The rotation (row vectors) of least angle with a R parallel to b, for unit a and any b;
// I where b is 0; a half turn about an axis perpendicular to a where b is antiparallel to a
// (glmls.reference._least_rotation).
mat3 mls3_least_rotation(vec3 a, vec3 b) {
    float norm = length(b);
    vec3 bh = norm > 0.0 ? b / norm : a;
    vec3 n = cross(a, bh);
    float c = dot(a, bh);
    mat3 K = mls3_cross_matrix(n);
    // Rodrigues for column vectors, Rc = I + K + K^2 / (1 + c); row vectors take Rc^T
    // = I - K + K^2 / (1 + c) (K antisymmetric)
    mat3 r = mat3(1.0) - K + (K * K) * (1.0 / max(1.0 + c, 1e-30));
    vec3 m = abs(a) + vec3(0.0, 1e-3, 2e-3);   // ties (a on an axis, a diagonal): the first
    vec3 helper = m.x <= m.y && m.x <= m.z ? vec3(1.0, 0.0, 0.0)
                : (m.y <= m.z ? vec3(0.0, 1.0, 0.0) : vec3(0.0, 0.0, 1.0));
    vec3 perp = normalize(cross(a, helper));
    mat3 half_turn = 2.0 * outerProduct(perp, perp) - mat3(1.0);
    return c < -1.0 + 1e-6 ? half_turn : r;
}

// The ridge share of an eigenvalue e of A against trace(A) (glmls.reference._ridge).
vec3 mls3_share(vec3 e, float trace) {
    vec3 x = trace > 0.0 ? max(e, vec3(0.0)) / trace : vec3(1.0);
    vec3 r = max(vec3(0.0), vec3(1.0) - x / MLS3_DEGENERATE_SHARE);
    return MLS3_DEGENERATE_SHARE * r * r;
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

// Targets near one line: whether B B^T's middle eigenvalue is below 1e-3 of its trace (its
// invariants say so), with B B^T's diagonal bd, off-diagonal bo = (01, 02, 12) and trace btr.
bool mls3_targets_on_a_line(mat3 B, out vec3 bd, out vec3 bo, out float btr) {
    mat3 BBt = B * transpose(B);
    bd = vec3(BBt[0][0], BBt[1][1], BBt[2][2]);
    bo = vec3(BBt[1][0], BBt[2][0], BBt[2][1]);
    btr = bd.x + bd.y + bd.z;
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
#if MLS_TRANSFORM == 0
    // (c2 bounds e_mid away from 0 first, so that rounding cannot pass det / c2 off as e_min)
    if (c2 > 2.0 * MLS3_DEGENERATE_SHARE * tr * tr && det > MLS3_DEGENERATE_SHARE * c2 * tr) {
        // every eigenvalue above 1e-3 trace(A): no ridge, N = A^-1 D
        vec3 l0 = vec3(sqrt(a.x), o.x, o.y);
        l0.yz /= l0.x;
        float l11 = sqrt(a.y - l0.y * l0.y);
        vec3 l1 = vec3(0.0, l11, (o.z - l0.z * l0.y) / l11);
        vec3 l2 = vec3(0.0, 0.0, sqrt(a.z - l0.z * l0.z - l1.z * l1.z));
        if (l2.z > 0.0 && l11 > 0.0) {
            return mat3(mls3_cholesky_apply(l0, l1, l2, D[0]),
                        mls3_cholesky_apply(l0, l1, l2, D[1]),
                        mls3_cholesky_apply(l0, l1, l2, D[2]));
        }
    }
    bool ridge = true;
#if MLS3_SOLVE_LATER
    mls3_solve_later = true;
    return mat3(0.0);
#endif
#else
    // the middle eigenvalue above 1e-3 trace(A): no ridge on the rotation
    bool ridge = !(c2 > 2.0 * MLS3_DEGENERATE_SHARE * tr * tr);
#endif
#if MLS3_SOLVE_LATER && MLS_TRANSFORM != 0
    mat3 B = mat3(vec3(a.x, o.x, o.y), vec3(o.x, a.y, o.z), vec3(o.y, o.z, a.z)) + D;
    vec3 bd, bo;
    float btr;
    bool ridge_b = mls3_targets_on_a_line(B, bd, bo, btr);
    float nb2 = dot(B[0], B[0]) + dot(B[1], B[1]) + dot(B[2], B[2]);
    if (ridge || ridge_b || !(determinant(B) > MLS3_POLAR_DET * nb2 * sqrt(nb2))) {
        mls3_solve_later = true;
        return mat3(0.0);
    }
    mls3_solve_polar = mls3_polar(B);
    mat3 NR = mls3_solve_polar - mat3(1.0);
#else
    mat3 A = mat3(vec3(a.x, o.x, o.y), vec3(o.x, a.y, o.z), vec3(o.y, o.z, a.z));
    mat3 B = A + D;
    vec3 e = vec3(0.0), v0 = vec3(1.0, 0.0, 0.0), v1 = vec3(0.0, 1.0, 0.0);
    vec3 v2 = vec3(0.0, 0.0, 1.0), share = vec3(0.0);
    float trace = tr;
    mat3 S2 = D;   // B' - A, for Horn's matrix
    if (ridge) {
        mls3_eigen3(a, o, e, v0, v1, v2);
        trace = max(e.x + e.y + e.z, 0.0);
        share = mls3_share(e, trace);
        // the largest eigenvalue's vector (A's principal axis), the middle one's share
        float emax = max(e.x, max(e.y, e.z));
        float emid = e.x + e.y + e.z - emax - min(e.x, min(e.y, e.z));
        vec3 axis = e.x == emax ? v0 : (e.y == emax ? v1 : v2);
        float share_mid = mls3_share(vec3(emid), trace).x;
        // rigid: Horn's rotation of B' = B + c |B| R0 (c = 0 unless the sources are near a
        // line)
        float normB = sqrt(dot(B[0], B[0]) + dot(B[1], B[1]) + dot(B[2], B[2]));
        S2 += (share_mid * normB) * mls3_least_rotation(axis, axis * B);
    }
    // targets near one line (B near rank 1, the sources spread or not): the rotation about
    // their line is free; the same rule with B B^T's middle eigenvalue and principal axis
    vec3 bd, bo;
    float btr;
    bool ridge_b = mls3_targets_on_a_line(B, bd, bo, btr);
    if (ridge_b) {
        vec3 eb, u0, u1, u2;
        mls3_eigen3(bd / btr, bo / btr, eb, u0, u1, u2);
        float bmax = max(eb.x, max(eb.y, eb.z));
        float bmid = eb.x + eb.y + eb.z - bmax - min(eb.x, min(eb.y, eb.z));
        vec3 axis_b = eb.x == bmax ? u0 : (eb.y == bmax ? u1 : u2);
        float share_b = mls3_share(vec3(bmid), max(eb.x + eb.y + eb.z, 0.0)).x;
        S2 += (share_b * sqrt(btr)) * mls3_least_rotation(axis_b, axis_b * B);
    }
    mat3 NR;
    // A proper rotation is B's orthogonal polar factor where det B > 0 (no reflection to
    // fix): by Newton's iteration where B is comfortably nonsingular, else Horn's quaternion.
    float nb2 = dot(B[0], B[0]) + dot(B[1], B[1]) + dot(B[2], B[2]);
    if (!ridge && !ridge_b && determinant(B) > MLS3_POLAR_DET * nb2 * sqrt(nb2)) {
        mls3_solve_polar = mls3_polar(B);
        NR = mls3_solve_polar - mat3(1.0);
    } else {
        NR = mls3_quaternion_minus_identity(mls3_horn(a, o, S2));
    }
#endif
    // trace(R^T B) - trace(A) = trace(D) + <R - I, B>, without cancellation
    float gain = D[0][0] + D[1][1] + D[2][2]
               + dot(NR[0], B[0]) + dot(NR[1], B[1]) + dot(NR[2], B[2]);
    float along = tr + gain;      // trace(R^T B)
#if MLS_TRANSFORM == 2
    // all targets in reach collapsed to one point: no rotation is defined, M = I
    return along > 1e-6 * tr ? NR : mat3(0.0);
#else
    // Umeyama's scale: trace(R^T B) / trace(A), minus 1 without cancellation
    float scale = along / tr;
    float scale1 = gain / tr;
    mat3 Nsim = scale * NR + scale1 * mat3(1.0);
#if MLS_TRANSFORM == 1
    return Nsim;
#else
    // affine: (A + g)^-1 (B + g M_sim) - I = (A + g)^-1 (D + g N_sim), g the ridge
    vec3 weight = share * trace;
    mat3 G = weight.x * outerProduct(v0, v0) + weight.y * outerProduct(v1, v1)
           + weight.z * outerProduct(v2, v2);
    // A + g has A's eigenvectors: its inverse is V diag(1 / (e + g)) V^T, without the
    // cancellations of an inverse through the determinant (A + g's condition is up to 1e3)
    vec3 lambda = e + weight;
    if (!(min(lambda.x, min(lambda.y, lambda.z)) > 0.0)) {
        return Nsim;
    }
    mat3 V = mat3(v0, v1, v2);
    vec3 il = 1.0 / lambda;
    mat3 scaled = mat3(il.x * v0, il.y * v1, il.z * v2);   // V diag(1 / lambda)
    return scaled * (transpose(V) * (D + G * Nsim));
#endif
#endif
}
