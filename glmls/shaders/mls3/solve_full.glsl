// The 3D solve's every branch in float64 (mls3/solve.glsl has the plain one in float32): the
// degenerate handle sets' rules of glmls.reference (and glmls.core.ridges: ridge3,
// least_rotation, rotation3) and Horn's rotation where B is near singular or reflects.
//
// Why float64: a ridge of 1e-3 trace(A) decides what the handles leave free, so it divides
// the rounding of the moments by 1e-3. In float32 that rounding (6e-8 of each sum, different
// at every point) breaks the rank of A and B that two, three or collinear handles give, and
// moves f by ~6e-5 of |M - I| |v - p*| from point to point (0.03 voxel 200 voxels from two
// handles trading places, and J, by differences of a twentieth of a voxel, by up to 0.5). The
// moments come from float32 handles and weights: the handles' differences and products are
// exact in float64, and a weight's rounding is the same for every entry of its handle's terms,
// which keeps the ranks. Only the points whose float32 moments leave the plain branch take
// this (mls3/core.glsl, mls3_finish_full): they sum their moments again in float64.
//
//   A = sum w p^T p^ (symmetric: diagonal a, off-diagonal o = (01, 02, 12)), D = sum w p^T e^,
//   B = A + D; rigid: R maximising trace(R^T B') by Horn's quaternion, B' = B + c |B| R0
//   (+ c' |B| R0' for targets near one line); similarity: R times Umeyama's scale; affine:
//   (A + g(A))^-1 (B + g(A) M_sim), through A's eigenvectors. Matrices are used as ``v * M``
//   (row vectors), as in mls3/solve.glsl.

// Cyclic Jacobi sweeps of a symmetric 3 x 3 (A, B B^T) and 4 x 4 (Horn's) matrix: quadratic
// convergence leaves off-diagonal elements below float64's rounding of the diagonal after
// these many (four reach float32's). The count is read through u_mls3_count so that no
// compiler knows it: unrolled, the sweeps would be most of a program's code (this file is
// inlined at every evaluation of f) and llvmpipe takes seconds more to compile it, for the
// few points that run it.
#define MLS3_FULL_SWEEPS3 (6 + min(u_mls3_count, 0))
#define MLS3_FULL_SWEEPS4 (6 + min(u_mls3_count, 0))
const double MLS3_FULL_SHARE = 1e-3lf;   // glmls.reference.DEGENERATE_SHARE

// One Jacobi rotation zeroing apq (app, aqq, apq the (p, q) block). Branch-free: apq == 0 is
// no rotation (t = 0).
void mls3_full_rotation(double app, double aqq, double apq, out double c, out double s,
                        out double t) {
    double theta = (aqq - app) / (2.0lf * apq);
    double sg = theta >= 0.0lf ? 1.0lf : -1.0lf;
    // theta * theta may overflow: t is then 0, as good as exact for so small an apq
    t = apq == 0.0lf ? 0.0lf : sg / (abs(theta) + sqrt(theta * theta + 1.0lf));
    c = inversesqrt(t * t + 1.0lf);
    s = t * c;
}

// the rotation of (p, q) in a 3 x 3: for the other index r the pair (arp, arq); vp, vq the
// eigenvector columns
void mls3_full_jacobi3(inout double app, inout double aqq, inout double apq,
                       inout double arp, inout double arq, inout dvec3 vp, inout dvec3 vq) {
    double c, s, t;
    mls3_full_rotation(app, aqq, apq, c, s, t);
    app -= t * apq;
    aqq += t * apq;
    apq = 0.0lf;
    double rp = arp, rq = arq;
    arp = c * rp - s * rq;
    arq = s * rp + c * rq;
    dvec3 p = vp, q = vq;
    vp = c * p - s * q;
    vq = s * p + c * q;
}

// Eigenvalues e and unit eigenvectors v0..v2 of the symmetric (diagonal a, off-diagonal o)
void mls3_full_eigen3(dvec3 a, dvec3 o, out dvec3 e, out dvec3 v0, out dvec3 v1,
                      out dvec3 v2) {
    double a00 = a.x, a11 = a.y, a22 = a.z, a01 = o.x, a02 = o.y, a12 = o.z;
    v0 = dvec3(1.0lf, 0.0lf, 0.0lf);
    v1 = dvec3(0.0lf, 1.0lf, 0.0lf);
    v2 = dvec3(0.0lf, 0.0lf, 1.0lf);
    for (int k = 0; k < MLS3_FULL_SWEEPS3; ++k) {
        mls3_full_jacobi3(a00, a11, a01, a02, a12, v0, v1);   // (0, 1), r = 2
        mls3_full_jacobi3(a00, a22, a02, a01, a12, v0, v2);   // (0, 2), r = 1
        mls3_full_jacobi3(a11, a22, a12, a01, a02, v1, v2);   // (1, 2), r = 0
    }
    e = dvec3(a00, a11, a22);
}

// the rotation of (p, q) in a 4 x 4: for the other indices r and s the pairs (arp, arq),
// (asp, asq)
void mls3_full_jacobi4(inout double app, inout double aqq, inout double apq,
                       inout double arp, inout double arq, inout double asp,
                       inout double asq, inout dvec4 vp, inout dvec4 vq) {
    double c, s, t;
    mls3_full_rotation(app, aqq, apq, c, s, t);
    app -= t * apq;
    aqq += t * apq;
    apq = 0.0lf;
    double rp = arp, rq = arq, sp = asp, sq = asq;
    arp = c * rp - s * rq;
    arq = s * rp + c * rq;
    asp = c * sp - s * sq;
    asq = s * sp + c * sq;
    dvec4 p = vp, q = vq;
    vp = c * p - s * q;
    vq = s * p + c * q;
}

// The unit quaternion (w, x, y, z) of the rotation maximising trace(R^T S), S = A + S2 (A
// symmetric: diagonal a, off-diagonal o): the eigenvector of the largest eigenvalue of
// Horn's symmetric 4 x 4 matrix, the antisymmetric parts from S2 alone (Horn 1987).
dvec4 mls3_full_horn(dvec3 a, dvec3 o, dmat3 S2) {
    // S2[i][j] in GLSL is the mathematical S2_ji
    double sxx = S2[0][0], syy = S2[1][1], szz = S2[2][2];
    double sxy = S2[1][0], syx = S2[0][1], sxz = S2[2][0], szx = S2[0][2];
    double syz = S2[2][1], szy = S2[1][2];
    double a00 = (a.x + a.y + a.z) + (sxx + syy + szz);
    double a11 = (a.x - a.y - a.z) + (sxx - syy - szz);
    double a22 = (a.y - a.x - a.z) + (syy - sxx - szz);
    double a33 = (a.z - a.x - a.y) + (szz - sxx - syy);
    double a01 = syz - szy, a02 = szx - sxz, a03 = sxy - syx;
    double a12 = 2.0lf * o.x + (sxy + syx), a13 = 2.0lf * o.y + (szx + sxz);
    double a23 = 2.0lf * o.z + (syz + szy);
    dvec4 v0 = dvec4(1.0lf, 0.0lf, 0.0lf, 0.0lf);
    dvec4 v1 = dvec4(0.0lf, 1.0lf, 0.0lf, 0.0lf);
    dvec4 v2 = dvec4(0.0lf, 0.0lf, 1.0lf, 0.0lf);
    dvec4 v3 = dvec4(0.0lf, 0.0lf, 0.0lf, 1.0lf);
    for (int k = 0; k < MLS3_FULL_SWEEPS4; ++k) {
        mls3_full_jacobi4(a00, a11, a01, a02, a12, a03, a13, v0, v1);   // (0, 1), r, s = 2, 3
        mls3_full_jacobi4(a00, a22, a02, a01, a12, a03, a23, v0, v2);   // (0, 2), r, s = 1, 3
        mls3_full_jacobi4(a00, a33, a03, a01, a13, a02, a23, v0, v3);   // (0, 3), r, s = 1, 2
        mls3_full_jacobi4(a11, a22, a12, a01, a02, a13, a23, v1, v2);   // (1, 2), r, s = 0, 3
        mls3_full_jacobi4(a11, a33, a13, a01, a03, a12, a23, v1, v3);   // (1, 3), r, s = 0, 2
        mls3_full_jacobi4(a22, a33, a23, a02, a03, a12, a13, v2, v3);   // (2, 3), r, s = 0, 1
    }
    // the largest eigenvalue's vector (the first of equals: the identity's where S = 0)
    dvec4 q = v0;
    double best = a00;
    q = a11 > best ? v1 : q;
    best = max(best, a11);
    q = a22 > best ? v2 : q;
    best = max(best, a22);
    q = a33 > best ? v3 : q;
    return normalize(q);
}

// R - I (row vectors) of the unit quaternion q = (w, x, y, z), without cancellation for
// small rotations and exactly 0 for (+-1, 0, 0, 0)
dmat3 mls3_full_quaternion_minus_identity(dvec4 q) {
    double w = q.x, x = q.y, y = q.z, z = q.w;
    // the rows of Rc - I are the columns of R - I, which a GLSL matrix is built from
    return dmat3(dvec3(-2.0lf * (y * y + z * z), 2.0lf * (x * y - w * z), 2.0lf * (x * z + w * y)),
                 dvec3(2.0lf * (x * y + w * z), -2.0lf * (x * x + z * z), 2.0lf * (y * z - w * x)),
                 dvec3(2.0lf * (x * z - w * y), 2.0lf * (y * z + w * x), -2.0lf * (x * x + y * y)));
}

// The rotation (row vectors) of least angle with a R parallel to b, for unit a and any b;
// I where b is 0; a half turn about an axis perpendicular to a where b is antiparallel to a
// (glmls.core.ridges.least_rotation).
dmat3 mls3_full_least_rotation(dvec3 a, dvec3 b) {
    double norm = length(b);
    dvec3 bh = norm > 0.0lf ? b / norm : a;
    dvec3 n = cross(a, bh);
    double c = dot(a, bh);
    // [n]x (mls3_cross_matrix); Rodrigues for column vectors, Rc = I + K + K^2 / (1 + c);
    // row vectors take Rc^T = I - K + K^2 / (1 + c) (K antisymmetric)
    dmat3 K = dmat3(dvec3(0.0lf, n.z, -n.y), dvec3(-n.z, 0.0lf, n.x), dvec3(n.y, -n.x, 0.0lf));
    dmat3 r = dmat3(1.0lf) - K + (K * K) * (1.0lf / max(1.0lf + c, 1e-300lf));
    dvec3 m = abs(a) + dvec3(0.0lf, 1e-3lf, 2e-3lf);   // ties (a on an axis, a diagonal): the first
    dvec3 helper = m.x <= m.y && m.x <= m.z ? dvec3(1.0lf, 0.0lf, 0.0lf)
                 : (m.y <= m.z ? dvec3(0.0lf, 1.0lf, 0.0lf) : dvec3(0.0lf, 0.0lf, 1.0lf));
    dvec3 perp = normalize(cross(a, helper));
    dmat3 half_turn = 2.0lf * outerProduct(perp, perp) - dmat3(1.0lf);
    return c < -1.0lf + 1e-6lf ? half_turn : r;
}

// The ridge share of eigenvalues e of A against trace(A) (glmls.core.ridges.ridge_matrix).
dvec3 mls3_full_share(dvec3 e, double trace) {
    dvec3 x = trace > 0.0lf ? max(e, dvec3(0.0lf)) / trace : dvec3(1.0lf);
    dvec3 r = max(dvec3(0.0lf), dvec3(1.0lf) - x / MLS3_FULL_SHARE);
    return MLS3_FULL_SHARE * r * r;
}

// B's principal axis and the share of B B^T's middle eigenvalue where the targets are near
// one line (B B^T's middle eigenvalue below 1e-3 of its trace): the rule of collinear
// sources applied to B B^T. false elsewhere.
bool mls3_full_targets_on_a_line(dmat3 B, out dvec3 axis, out double share, out double btr) {
    dmat3 BBt = B * transpose(B);
    dvec3 bd = dvec3(BBt[0][0], BBt[1][1], BBt[2][2]);
    dvec3 bo = dvec3(BBt[1][0], BBt[2][0], BBt[2][1]);
    btr = bd.x + bd.y + bd.z;
    double bc2 = bd.x * bd.y + bd.x * bd.z + bd.y * bd.z - dot(bo, bo);
    axis = dvec3(1.0lf, 0.0lf, 0.0lf);
    share = 0.0lf;
    if (!(btr > 0.0lf) || bc2 > 2.0lf * MLS3_FULL_SHARE * btr * btr) {
        return false;
    }
    dvec3 eb, u0, u1, u2;
    mls3_full_eigen3(bd / btr, bo / btr, eb, u0, u1, u2);
    double bmax = max(eb.x, max(eb.y, eb.z));
    double bmid = eb.x + eb.y + eb.z - bmax - min(eb.x, min(eb.y, eb.z));
    axis = eb.x == bmax ? u0 : (eb.y == bmax ? u1 : u2);
    share = mls3_full_share(dvec3(bmid), max(eb.x + eb.y + eb.z, 0.0lf)).x;
    return true;
}

// N = M - I from A (diagonal a, off-diagonal o) and D about p* and q*, every rule of
// glmls.reference; spread as mls3_solve's.
dmat3 mls3_solve_full(dvec3 a, dvec3 o, dmat3 D, double spread) {
    double mu = a.x + a.y + a.z;
    bool zero = D[0] == dvec3(0.0lf) && D[1] == dvec3(0.0lf) && D[2] == dvec3(0.0lf);
    if (!(mu > 1e-13lf * spread) || zero) {
        return dmat3(0.0lf);
    }
    double inv = 1.0lf / mu;
    a *= inv;
    o *= inv;
    D *= inv;
    double tr = a.x + a.y + a.z;
    dmat3 A = dmat3(dvec3(a.x, o.x, o.y), dvec3(o.x, a.y, o.z), dvec3(o.y, o.z, a.z));
    dmat3 B = A + D;
    dvec3 e, v0, v1, v2;
    mls3_full_eigen3(a, o, e, v0, v1, v2);
    double trace = max(e.x + e.y + e.z, 0.0lf);
    dvec3 share = mls3_full_share(e, trace);
    // the largest eigenvalue's vector (A's principal axis), the middle one's share: rigid
    // takes Horn's rotation of B' = B + c |B| R0 (c = 0 unless the sources are near a line)
    double emax = max(e.x, max(e.y, e.z));
    double emid = e.x + e.y + e.z - emax - min(e.x, min(e.y, e.z));
    dvec3 axis = e.x == emax ? v0 : (e.y == emax ? v1 : v2);
    double share_mid = mls3_full_share(dvec3(emid), trace).x;
    double normB = sqrt(dot(B[0], B[0]) + dot(B[1], B[1]) + dot(B[2], B[2]));
    dmat3 S2 = D + (share_mid * normB) * mls3_full_least_rotation(axis, axis * B);
    // targets near one line (B near rank 1, the sources spread or not): the rotation about
    // their line is free; the same rule with B B^T's middle eigenvalue and principal axis
    dvec3 axis_b;
    double share_b, btr;
    bool line = mls3_full_targets_on_a_line(B, axis_b, share_b, btr);
    if (line) {
        S2 += (share_b * sqrt(btr)) * mls3_full_least_rotation(axis_b, axis_b * B);
    }
    dmat3 NR = mls3_full_quaternion_minus_identity(mls3_full_horn(a, o, S2));
    // no ridge, the targets off a line and det B > 0: R is B's own polar factor, whose
    // derivative J takes (mls3/core.glsl, mls3_centre)
    if (share_mid == 0.0lf && !line && determinant(B) > 0.0lf) {
        mls3_solve_polar = mat3(NR + dmat3(1.0lf));
    }
    // trace(R^T B) - trace(A) = trace(D) + <R - I, B>, without cancellation
    double gain = D[0][0] + D[1][1] + D[2][2]
                + dot(NR[0], B[0]) + dot(NR[1], B[1]) + dot(NR[2], B[2]);
    double along = tr + gain;   // trace(R^T B)
#if MLS_TRANSFORM == 2
    // all targets in reach collapsed to one point: no rotation is defined, M = I
    return along > 1e-6lf * tr ? NR : dmat3(0.0lf);
#else
    // Umeyama's scale: trace(R^T B) / trace(A), minus 1 without cancellation
    dmat3 Nsim = (along / tr) * NR + (gain / tr) * dmat3(1.0lf);
#if MLS_TRANSFORM == 1
    return Nsim;
#else
    // affine: (A + g)^-1 (D + g N_sim), g the ridge; A + g has A's eigenvectors, its inverse
    // V diag(1 / (e + g)) V^T (A + g's condition is up to 1e3 without cancellations)
    dvec3 weight = share * trace;
    dmat3 G = weight.x * outerProduct(v0, v0) + weight.y * outerProduct(v1, v1)
            + weight.z * outerProduct(v2, v2);
    dvec3 lambda = e + weight;
    if (!(min(lambda.x, min(lambda.y, lambda.z)) > 0.0lf)) {
        return Nsim;
    }
    dmat3 V = dmat3(v0, v1, v2);
    dvec3 il = 1.0lf / lambda;
    dmat3 scaled = dmat3(il.x * v0, il.y * v1, il.z * v2);   // V diag(1 / lambda)
    // no ridge: N = A^-1 D, the plain solve (mls3_solve_plain)
    mls3_solve_plain = share == dvec3(0.0lf);
    return scaled * (transpose(V) * (D + G * Nsim));
#endif
#endif
}
