// Moving Least Squares deformation (Schaefer, McPhail & Warren 2006) with the distance
// weights of Table 1 of "Extensions to the MLS method for image deformation".
//
// The one MLS implementation of glmls: every pass that needs f, M or T includes this file.
//
// Expects, before it (prepended by glmls.shaders):
//   MLS_WEIGHT        0 idw, 1 cressman, 2 shepard, 3 gaussian, 4 linear
//   MLS_TRANSFORM     0 affine, 1 similarity, 2 rigid
//   MLS_INTERPOLATING 0 or 1: multiply the weight by 1 / d^(2 alpha)
//   MLS_ALPHA_ONE     0 or 1: alpha == 1, so no pow() is needed
//   MLS_UNROLL        0, or 16 / 64: at most that many handles, read at constant indices
//   MLS_BINS          0 or 1: handles sorted into bins, visit only those in reach (below)
//   a handle storage defining  int mls_handle_count()  and  vec4 mls_handle(int i),
//   the handle as (p.x, p.y, q.x, q.y).
//
// One pass over the handles (mls_begin, mls_accumulate per handle, mls_finish) accumulates
// every weighted moment; mls_eval(v) runs it over all handles, and callers that visit the
// handles otherwise (tiles in shared memory, a spatial grid of bins) call the three parts.
//
// All coordinates are "scaled": (pixel - u_center) / u_scale, so that float32 keeps
// sub-millipixel precision on large images. The host scales s and R to match.
//
// Row-vector convention of the paper (eq. 1): f(v) = v M + T. M is returned as
// vec4(m00, m01, m10, m11), i.e. f.x = v.x m00 + v.y m10, f.y = v.x m01 + v.y m11.

uniform float u_alpha;      // idw / interpolating power
uniform float u_log2_s;     // log2 of the scaled idw s; -1e30 when s == 0
uniform float u_radius;     // scaled influence radius R
uniform float u_hit2;       // squared snapping distance (scaled)
uniform bool u_snap;        // weight is (effectively) infinite at d = 0: f(p_i) = q_i exactly

struct MLSResult {
    vec2 f;   // f(v), scaled coordinates
    vec4 M;   // linear part, see above
};

float mls_pow(float r) {
#if MLS_ALPHA_ONE
    return r;
#else
    return r > 0.0 ? exp2(u_alpha * log2(r)) : 0.0;
#endif
}

// Weight of a handle at squared distance d2. All weights are divided by a common factor
// that depends on m (the squared distance to the nearest handle in use) so that the largest
// weight is about 1: MLS is invariant to a common factor, and float32 neither overflows
// (idw, shepard near a handle) nor underflows (gaussian far from every handle).
float mls_weight(float d2, float m, float inv_m, float sigma) {
    float w;
#if MLS_WEIGHT == 0
    // 1 / (s + d^(2 alpha)), times s + m^alpha; sigma = s / m^alpha
    w = (sigma + 1.0) / (sigma + mls_pow(d2 * inv_m));
#elif MLS_WEIGHT == 1
    float R2 = u_radius * u_radius;
    w = max(0.0, (R2 - d2) / (R2 + d2));
#elif MLS_WEIGHT == 2
    // (R - d) / (R d), times sqrt(m)
    float d = sqrt(d2);
    w = d < u_radius ? (1.0 - d / u_radius) * sqrt(m / d2) : 0.0;
#elif MLS_WEIGHT == 3
    w = exp(-(d2 - m) / (u_radius * u_radius));
#elif MLS_WEIGHT == 4
    w = max(0.0, u_radius - sqrt(d2));
#else
#error "unknown MLS_WEIGHT"
#endif
#if MLS_INTERPOLATING
    w = w > 0.0 ? w / mls_pow(d2 * inv_m) : 0.0;   // 0, not 0/0, out of reach
#endif
    return w;
}

MLSResult mls_identity(vec2 v) {
    MLSResult r;
    r.f = v;
    r.M = vec4(1.0, 0.0, 0.0, 1.0);
    return r;
}

// N = M - I for similarity / rigid, from mu = sum w |p^|^2 and the displacement moments
// D (see mls_finish). M = [[A, B], [-B, A]] / norm with A = mu + D11 + D22, B = D12 - D21.
vec4 mls_rotation_scale(float mu, vec4 D, float spread) {
    // Source handles in reach coincide (their spread about p* is float32 noise against their
    // spread about v): only a translation is defined.
    if (!(mu > 1e-13 * spread)) {
        return vec4(0.0);
    }
    float B = D.y - D.z;
#if MLS_TRANSFORM == 2
    float A = mu + D.x + D.w;
    float n = sqrt(A * A + B * B);
    // Targets collapsed to a point: no rotation is defined, keep the identity.
    if (n <= 1e-6 * mu) {
        return vec4(0.0);
    }
    // A / n - 1 without cancellation for small rotations
    float c1 = A > 0.0 ? -B * B / (n * (A + n)) : A / n - 1.0;
    return vec4(c1, B / n, -B / n, c1);
#else
    float a = (D.x + D.w) / mu;
    return vec4(a, B / mu, -B / mu, a);
#endif
}

// One evaluation at v is two passes over the handles (mls_eval; callers that visit the
// handles otherwise, e.g. a spatial grid of bins, call the parts themselves):
//
// 1. mls_nearest_add: the nearest handle (for snapping) and the normalisation distance m,
//    a min over d^2, a few operations per handle;
// 2. mls_accumulate: every weighted moment at once, as plain sums about the nearest handle
//    o (P = p - p_o, E = e - e_o); mls_finish turns them into the means and central moments
//    (C = sum w P P^T - (sum w P)(sum w P)^T / W). About o, not the origin: differences of
//    nearby float32 values are exact, so P keeps its precision even for points far from a
//    tight cluster of handles, and where one handle dominates the weights (next to it) it is
//    o itself, adds nothing to the sums, and the correction term is second order in the
//    small weights, so no digits are lost. (A running-centroid Welford update is as precise
//    here and costs a division per handle more.)
//
// Both loops are branch-free: llvmpipe (and GPUs, per warp) run both sides of a branch
// whenever lanes disagree, so a "rare" branch costs its full price on every handle.
// Working with displacements e = q - p keeps the identity exact and small deformations
// precise: f(v) = v + e* + (v - p*) N with N = M - I.
struct MLSNearest {
    float d2min;    // squared distance of the nearest handle
    float d2far;    // ... of the nearest beyond the snapping distance
    vec4 h;         // the nearest handle
};

MLSNearest mls_nearest_begin() {
    MLSNearest n;
    n.d2min = 3.0e38;
    n.d2far = 3.0e38;
    n.h = vec4(0.0);
    return n;
}

// ``use``: false for an empty slot (see MLS_UNROLL), which changes nothing.
void mls_nearest_add(inout MLSNearest n, vec4 h, vec2 v, bool use) {
    vec2 dp = h.xy - v;
    float d2 = use ? dot(dp, dp) : 3.0e38;
    bool nearer = d2 < n.d2min;
    n.h = nearer ? h : n.h;
    n.d2min = min(n.d2min, d2);
    n.d2far = min(n.d2far, d2 > u_hit2 ? d2 : 3.0e38);
}

struct MLSAccum {
    vec2 v;
    bool hit;       // v snaps to handle o: f(v) = its q
    vec4 o;         // the nearest handle: moments are taken about it
    float m;        // normalisation distance (see mls_weight)
    float inv_m;    // 1 / m
    float sigma;    // idw: s / m^alpha
    float W;        // sum w
    vec2 P;         // sum w P, with P = p - p_o
    vec2 E;         // sum w E, with E = e - e_o, e = q - p
    vec3 PP;        // sum w P P^T as (xx, xy, yy)
    vec4 PE;        // sum w P_i E_j as (11, 12, 21, 22)
    float spread;   // sum w |p - v|^2, the yardstick for "coincident"
};

MLSAccum mls_begin(vec2 v, MLSNearest n) {
    MLSAccum a;
    a.v = v;
    a.hit = u_snap && n.d2min <= u_hit2;
    a.o = n.h;
    a.m = a.hit ? n.d2far : max(n.d2min, u_hit2);
    a.inv_m = 1.0 / a.m;
#if MLS_WEIGHT == 0
    a.sigma = min(exp2(u_log2_s - u_alpha * log2(a.m)), 1e30);
#else
    a.sigma = 0.0;
#endif
    a.W = 0.0;
    a.P = vec2(0.0);
    a.E = vec2(0.0);
    a.PP = vec3(0.0);
    a.PE = vec4(0.0);
    a.spread = 0.0;
    return a;
}

// The weight at a.v of a handle at squared distance d2. The snapped handle (and duplicates
// of it) is left out: its weight is infinite and its p^ zero, see mls_finish.
float mls_handle_weight(MLSAccum a, float d2) {
    return (u_snap && d2 <= u_hit2) ? 0.0 : mls_weight(d2, a.m, a.inv_m, a.sigma);
}

void mls_accumulate(inout MLSAccum a, vec4 h, bool use) {
    vec2 dp = h.xy - a.v;
    float d2 = dot(dp, dp);
    // An empty slot gets no weight (zeros: every term below is then 0).
    float w = use ? mls_handle_weight(a, d2) : 0.0;
    // Moments about the nearest handle, not about the origin: the differences of nearby
    // float32 values are exact, the nearest handle (the heaviest) adds nothing to them, and
    // the central moments in mls_finish lose no digits where one handle dominates.
    vec2 P = h.xy - a.o.xy;
    vec2 E = (h.zw - h.xy) - (a.o.zw - a.o.xy);
    vec2 wP = w * P;
    a.W += w;
    a.P += wP;
    a.E += w * E;
    a.PP += vec3(wP.x * P.x, wP.x * P.y, wP.y * P.y);
    a.PE += vec4(wP.x * E.x, wP.x * E.y, wP.y * E.x, wP.y * E.y);
    a.spread += w * d2;
}

MLSResult mls_finish(MLSAccum a) {
    vec2 v = a.v;
    bool hit = a.hit;
    if (!hit && !(a.W > 0.0)) {
        return mls_identity(v);   // no handle reaches v (or there are none)
    }
    vec2 pst = a.o.xy;
    vec2 est = a.o.zw - a.o.xy;
    vec3 A = a.PP;
    vec4 D = a.PE;
    if (!hit) {
        // p* = p_o + sum w P / W, e* likewise, and the moments about them
        vec2 dp = a.P / a.W;
        vec2 de = a.E / a.W;
        pst += dp;
        est += de;
        A -= vec3(a.P.x * dp.x, a.P.x * dp.y, a.P.y * dp.y);
        D -= vec4(a.P.x * de.x, a.P.x * de.y, a.P.y * de.x, a.P.y * de.y);
    }
    // Snapped: p* = p_o and q* = q_o exactly, and the moments about them are the sums.
    float a11 = A.x, a12 = A.y, a22 = A.z;
    float spread = a.spread;

    float mu = a11 + a22;
    vec4 N;   // M - I
#if MLS_TRANSFORM == 0
    float det = a11 * a22 - a12 * a12;
    if (mu > 1e-13 * spread && det > 1e-5 * mu * mu) {
        // M = A^-1 (A + D) = I + A^-1 D, with A = [[a11, a12], [a12, a22]]
        vec2 r0 = vec2(a22, -a12) / det;
        vec2 r1 = vec2(-a12, a11) / det;
        N = vec4(r0.x * D.x + r0.y * D.z, r0.x * D.y + r0.y * D.w,
                 r1.x * D.x + r1.y * D.z, r1.x * D.y + r1.y * D.w);
    } else {
        // Fewer than 3 non-collinear handles in reach: the similarity solution.
        N = mls_rotation_scale(mu, D, spread);
    }
#else
    N = mls_rotation_scale(mu, D, spread);
#endif

    // f(v) = q* + (v - p*) M = v + e* + (v - p*) N
    vec2 vp = v - pst;
    MLSResult r;
    r.M = N + vec4(1.0, 0.0, 0.0, 1.0);
    r.f = v + est + vec2(vp.x * N.x + vp.y * N.z, vp.x * N.y + vp.y * N.w);
    return r;
}

#if MLS_UNROLL
// MLS_UNROLL (16 or 64) handle slots at constant indices, unrolled by the preprocessor: with a
// constant index llvmpipe loads a handle once for all lanes instead of gathering it per lane
// (1.5x faster). Slots from mls_handle_count() on are zero and given no weight.
#define MLS_R4(F, i) F(i) F(i + 1) F(i + 2) F(i + 3)
#define MLS_R16(F, i) MLS_R4(F, i) MLS_R4(F, i + 4) MLS_R4(F, i + 8) MLS_R4(F, i + 12)
#define MLS_R64(F, i) MLS_R16(F, i) MLS_R16(F, i + 16) MLS_R16(F, i + 32) MLS_R16(F, i + 48)
#define MLS_NEAR(i) mls_nearest_add(near, mls_handle(i), v, (i) < n);
#define MLS_ACC(i) mls_accumulate(a, mls_handle(i), (i) < n);
#endif

#if MLS_BINS
// Handles sorted by the bins of a square grid (glmls/bins.py): bin b's handles are
// mls_handle(mls_bin_start[b]) .. mls_handle(mls_bin_start[b + 1] - 1), bins row-major.
layout(std430, binding = 5) readonly buffer MLSBinStarts {
    int mls_bin_start[];
};
uniform vec2 u_bin_origin;   // lower corner of bin (0, 0), scaled
uniform float u_bin_size;    // bin side, scaled
uniform ivec2 u_bin_dims;    // bins per row, rows
uniform float u_bin_reach;   // R (compact weights) or R sqrt(cut) (gaussian), scaled
uniform float u_bin_cut;     // gaussian: ln(N / tau), see mls_weight_bound

// The bins meeting the square of half-side r around v (clamped to the grid).
void mls_bin_range(vec2 v, float r, out ivec2 lo, out ivec2 hi) {
    vec2 a = floor((v - r - u_bin_origin) / u_bin_size);
    vec2 b = floor((v + r - u_bin_origin) / u_bin_size);
    lo = ivec2(clamp(a, vec2(0.0), vec2(u_bin_dims - 1)));
    hi = ivec2(clamp(b, vec2(0.0), vec2(u_bin_dims - 1)));
}

// Whether the nearest handle found in the bins lo..hi, those meeting the square of
// half-side ``side`` around v, is the nearest of all: it is within ``side`` (every handle
// outside the square is farther), or the bins are the whole grid. The same for the nearest
// beyond the snapping distance where v snaps (the normalisation distance, see mls_begin).
bool mls_nearest_certain(MLSNearest near, float side, ivec2 lo, ivec2 hi) {
    if (all(equal(lo, ivec2(0))) && all(equal(hi, u_bin_dims - 1))) {
        return true;
    }
    bool snapped = u_snap && near.d2min <= u_hit2;
    float side2 = side * side;
    return near.d2min <= side2 && (!snapped || near.d2far <= side2);
}

// The sorted handles of bins x0..x1 of bin row y: indices run.x .. run.y - 1 (none when
// x1 < x0, an empty chord).
ivec2 mls_bin_run(int y, int x0, int x1) {
    int row = y * u_bin_dims.x;
    return ivec2(mls_bin_start[row + x0], mls_bin_start[row + max(x1, x0 - 1) + 1]);
}

// The nearest handle among those in the bins lo..hi.
void mls_nearest_bins(inout MLSNearest near, vec2 v, ivec2 lo, ivec2 hi) {
    for (int y = lo.y; y <= hi.y; ++y) {
        ivec2 run = mls_bin_run(y, lo.x, hi.x);
        for (int i = run.x; i < run.y; ++i) {
            mls_nearest_add(near, mls_handle(i), v, true);
        }
    }
}

#if MLS_WEIGHT == 3
// 2^-24 = glmls.bins.GAUSSIAN_TOLERANCE: the left-out weights sum to less than this share.
const float MLS_GAUSSIAN_TOLERANCE = 5.9604645e-8;

// W1, a lower bound of the total weight at a.v for the gaussian cut (glmls/bins.py): the
// weights of the handles in the bins lo..hi that every cut keeps (weight >= tolerance, so
// within the disc whose bins pass 2 walks), and at least the nearest handle's, 1.
float mls_weight_bound(MLSAccum a, ivec2 lo, ivec2 hi) {
    float w1 = 0.0;
    for (int y = lo.y; y <= hi.y; ++y) {
        ivec2 run = mls_bin_run(y, lo.x, hi.x);
        for (int i = run.x; i < run.y; ++i) {
            vec2 dp = mls_handle(i).xy - a.v;
            float d2 = dot(dp, dp);
            float w = mls_handle_weight(a, d2);
            w1 += w >= MLS_GAUSSIAN_TOLERANCE ? w : 0.0;
        }
    }
    return max(w1, 1.0);
}
#endif

// The columns of bin row y that meet the disc of radius r around v (within lo.x..hi.x):
// the disc's chord at the row's nearest edge. With the rows this visits about the disc's
// area of handles, not its square's (4 / pi as many).
ivec2 mls_bin_chord(vec2 v, float r, int y, ivec2 lo, ivec2 hi) {
    float y0 = u_bin_origin.y + float(y) * u_bin_size;
    float dy = max(0.0, max(y0 - v.y, v.y - (y0 + u_bin_size)));
    float half_width = sqrt(max(r * r - dy * dy, 0.0));
    float a = floor((v.x - half_width - u_bin_origin.x) / u_bin_size);
    float b = floor((v.x + half_width - u_bin_origin.x) / u_bin_size);
    return ivec2(clamp(a, float(lo.x), float(hi.x + 1)), clamp(b, float(lo.x - 1), float(hi.x)));
}
#endif

// Both passes over every handle, in storage order (the plain evaluation).
void mls_nearest_all(inout MLSNearest near, vec2 v) {
    int n = mls_handle_count();
    for (int i = 0; i < n; ++i) {
        mls_nearest_add(near, mls_handle(i), v, true);
    }
}

void mls_accumulate_all(inout MLSAccum a) {
    int n = mls_handle_count();
    for (int i = 0; i < n; ++i) {
        mls_accumulate(a, mls_handle(i), true);
    }
}

MLSResult mls_eval(vec2 v) {
#if MLS_BINS
    // Pass 1 finds the nearest handle, first in the bins within one bin side of v, then
    // within reach: a compact weight is 0 beyond R, so if none is there no handle reaches
    // v. The gaussian goes on in squares of twice the side until the nearest is certain.
    // Where a square or the disc spans more bin rows than there are handles (a few handles
    // far apart), walking its rows costs more than visiting every handle: that is done.
    int n = mls_handle_count();
    ivec2 lo, hi;
    MLSNearest near = mls_nearest_begin();
    mls_bin_range(v, u_bin_size, lo, hi);
    mls_nearest_bins(near, v, lo, hi);
    ivec2 lo1 = lo, hi1 = hi;
    float side = u_bin_size;
    for (int k = 0; k < 40 && !mls_nearest_certain(near, side, lo, hi); ++k) {
#if MLS_WEIGHT != 3
        if (side >= u_bin_reach) {
            break;
        }
#endif
        side = max(2.0 * side, u_bin_reach);
        mls_bin_range(v, side, lo, hi);
        if (hi.y - lo.y >= n) {
            mls_nearest_all(near, v);
            break;
        }
        mls_nearest_bins(near, v, lo, hi);   // the handles seen twice change no minimum
    }
    MLSAccum a = mls_begin(v, near);
    float r = u_bin_reach;
#if MLS_WEIGHT == 3
    // gaussian: weights below tau W1 / N of the nearest one's are left out (glmls/bins.py)
    float cut = u_bin_cut - log(mls_weight_bound(a, lo1, hi1));
    r = sqrt(a.m + cut * u_radius * u_radius);
#endif
    // Pass 2 over the disc of radius r, row by row (or over every handle, which adds
    // only weights that are zero or within the cut's tolerance).
    mls_bin_range(v, r, lo, hi);
    if (hi.y - lo.y >= n) {
        mls_accumulate_all(a);
        return mls_finish(a);
    }
    for (int y = lo.y; y <= hi.y; ++y) {
        ivec2 columns = mls_bin_chord(v, r, y, lo, hi);
        ivec2 run = mls_bin_run(y, columns.x, columns.y);
        for (int i = run.x; i < run.y; ++i) {
            mls_accumulate(a, mls_handle(i), true);
        }
    }
    return mls_finish(a);
#else
    int n = mls_handle_count();
    MLSNearest near = mls_nearest_begin();
#if MLS_UNROLL == 16
    MLS_R16(MLS_NEAR, 0)
#elif MLS_UNROLL == 64
    MLS_R64(MLS_NEAR, 0)
#else
    mls_nearest_all(near, v);
#endif
    MLSAccum a = mls_begin(v, near);
#if MLS_UNROLL == 16
    MLS_R16(MLS_ACC, 0)
#elif MLS_UNROLL == 64
    MLS_R64(MLS_ACC, 0)
#else
    mls_accumulate_all(a);
#endif
    return mls_finish(a);
#endif
}
