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
//   a handle storage defining  int mls_handle_count()  and  vec4 mls_handle(int i),
//   the handle as (p.x, p.y, q.x, q.y).
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
float mls_weight(float d2, float m) {
    float w;
#if MLS_WEIGHT == 0
    // 1 / (s + d^(2 alpha)), times m^alpha
    float sigma = min(exp2(u_log2_s - u_alpha * log2(m)), 1e30);
    w = (sigma + 1.0) / (sigma + mls_pow(d2 / m));
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
    w /= mls_pow(d2 / m);
#endif
    return w;
}

MLSResult mls_identity(vec2 v) {
    MLSResult r;
    r.f = v;
    r.M = vec4(1.0, 0.0, 0.0, 1.0);
    return r;
}

// Similarity / rigid matrix [[A, B], [-B, A]] / norm from the weighted moments.
vec4 mls_rotation_scale(float mu, float A, float B, float spread) {
    // Source handles in reach coincide (their spread about p* is float32 noise against their
    // spread about v): only a translation is defined.
    if (!(mu > 1e-13 * spread)) {
        return vec4(1.0, 0.0, 0.0, 1.0);
    }
#if MLS_TRANSFORM == 2
    float n = sqrt(A * A + B * B);
    // Targets collapsed to a point: no rotation is defined, keep the identity.
    if (n <= 1e-6 * mu) {
        return vec4(1.0, 0.0, 0.0, 1.0);
    }
    return vec4(A, B, -B, A) / n;
#else
    return vec4(A, B, -B, A) / mu;
#endif
}

MLSResult mls_eval(vec2 v) {
    int n = mls_handle_count();
    if (n == 0) {
        return mls_identity(v);
    }

    // Pass 0: the nearest handle (for snapping) and the normalisation distance m.
    float d2min = 3.0e38;
    float d2far = 3.0e38;   // nearest beyond the snapping distance
    int imin = 0;
    for (int i = 0; i < n; ++i) {
        vec2 dp = mls_handle(i).xy - v;
        float d2 = dot(dp, dp);
        if (d2 < d2min) {
            d2min = d2;
            imin = i;
        }
        if (d2 > u_hit2) {
            d2far = min(d2far, d2);
        }
    }
    bool hit = u_snap && d2min <= u_hit2;
    float m = hit ? d2far : max(d2min, u_hit2);

    // Pass 1: weighted centroids p*, q*, relative to v for precision.
    vec2 pst;
    vec2 qst;
    if (hit) {
        vec4 h = mls_handle(imin);
        pst = h.xy - v;
        qst = h.zw - v;
    } else {
        float W = 0.0;
        vec2 sp = vec2(0.0);
        vec2 sq = vec2(0.0);
        for (int i = 0; i < n; ++i) {
            vec4 h = mls_handle(i);
            vec2 dp = h.xy - v;
            float w = mls_weight(dot(dp, dp), m);
            W += w;
            sp += w * dp;
            sq += w * (h.zw - v);
        }
        if (!(W > 0.0)) {
            return mls_identity(v);   // no handle reaches v
        }
        pst = sp / W;
        qst = sq / W;
    }

    // Pass 2: moments of p^ = p - p*, q^ = q - q*.
    float spread = 0.0;   // sum w |p - v|^2, the yardstick for "coincident"
    float a11 = 0.0, a12 = 0.0, a22 = 0.0;
    vec4 b = vec4(0.0);   // b_ij = sum w p^_i q^_j as (b11, b12, b21, b22)
    for (int i = 0; i < n; ++i) {
        vec4 h = mls_handle(i);
        vec2 dp = h.xy - v;
        float d2 = dot(dp, dp);
        if (hit && d2 <= u_hit2) {
            continue;   // the snapped handle: its p^ is 0 and its weight infinite
        }
        float w = mls_weight(d2, m);
        vec2 ph = dp - pst;
        vec2 qh = (h.zw - v) - qst;
        spread += w * dot(dp, dp);
        a11 += w * ph.x * ph.x;
        a12 += w * ph.x * ph.y;
        a22 += w * ph.y * ph.y;
        b += w * vec4(ph.x * qh.x, ph.x * qh.y, ph.y * qh.x, ph.y * qh.y);
    }

    float mu = a11 + a22;
    float A = b.x + b.w;   // sum w p^ . q^
    float B = b.y - b.z;   // sum w p^ x q^
    vec4 M;
#if MLS_TRANSFORM == 0
    float det = a11 * a22 - a12 * a12;
    if (mu > 1e-13 * spread && det > 1e-5 * mu * mu) {
        // M = A^-1 B with A = [[a11, a12], [a12, a22]]
        vec2 r0 = vec2(a22, -a12) / det;
        vec2 r1 = vec2(-a12, a11) / det;
        M = vec4(r0.x * b.x + r0.y * b.z, r0.x * b.y + r0.y * b.w,
                 r1.x * b.x + r1.y * b.z, r1.x * b.y + r1.y * b.w);
    } else {
        // Fewer than 3 non-collinear handles in reach: the similarity solution.
        M = mls_rotation_scale(mu, A, B, spread);
    }
#else
    M = mls_rotation_scale(mu, A, B, spread);
#endif

    // f(v) = (v - p*) M + q*, with v - p* = -pst.
    MLSResult r;
    r.M = M;
    r.f = v + qst - vec2(pst.x * M.x + pst.y * M.z, pst.x * M.y + pst.y * M.w);
    return r;
}
