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

// N = M - I for similarity / rigid, from mu = sum w |p^|^2 and the displacement moments
// D (see mls_eval). M = [[A, B], [-B, A]] / norm with A = mu + D11 + D22, B = D12 - D21.
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

    // Centroids and moments are taken relative to the nearest handle (o, oq): differences of
    // nearby float32 values are exact, so p^ = p - p* keeps its precision even for points far
    // from a tight cluster of handles.
    vec4 ho = mls_handle(imin);
    vec2 o = ho.xy;
    vec2 oq = ho.zw;

    // Pass 1: weighted centroids p* = o + pst and displacement e* = e(o) + est, where
    // e(p_i) = q_i - p_i. Working with displacements keeps the identity exact and small
    // deformations precise: f(v) = v + e* + (v - p*) N with N = M - I.
    vec2 eo = oq - o;
    vec2 pst = vec2(0.0);
    vec2 est = vec2(0.0);
    if (!hit) {   // when snapped, p* = p_i and q* = q_i exactly
        float W = 0.0;
        vec2 sp = vec2(0.0);
        vec2 se = vec2(0.0);
        for (int i = 0; i < n; ++i) {
            vec4 h = mls_handle(i);
            vec2 dp = h.xy - v;
            float w = mls_weight(dot(dp, dp), m);
            W += w;
            sp += w * (h.xy - o);
            se += w * ((h.zw - h.xy) - eo);
        }
        if (!(W > 0.0)) {
            return mls_identity(v);   // no handle reaches v
        }
        pst = sp / W;
        est = se / W;
    }

    // Pass 2: moments of p^ = p - p* and of the displacement e^ = e - e* (q^ = p^ + e^).
    float spread = 0.0;   // sum w |p - v|^2, the yardstick for "coincident"
    float a11 = 0.0, a12 = 0.0, a22 = 0.0;
    vec4 D = vec4(0.0);   // D_ij = sum w p^_i e^_j as (D11, D12, D21, D22)
    for (int i = 0; i < n; ++i) {
        vec4 h = mls_handle(i);
        vec2 dp = h.xy - v;
        float d2 = dot(dp, dp);
        if (hit && d2 <= u_hit2) {
            continue;   // the snapped handle: its p^ is 0 and its weight infinite
        }
        float w = mls_weight(d2, m);
        vec2 ph = (h.xy - o) - pst;
        vec2 eh = ((h.zw - h.xy) - eo) - est;
        spread += w * d2;
        a11 += w * ph.x * ph.x;
        a12 += w * ph.x * ph.y;
        a22 += w * ph.y * ph.y;
        D += w * vec4(ph.x * eh.x, ph.x * eh.y, ph.y * eh.x, ph.y * eh.y);
    }

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
    vec2 vp = (v - o) - pst;
    MLSResult r;
    r.M = N + vec4(1.0, 0.0, 0.0, 1.0);
    r.f = v + (eo + est) + vec2(vp.x * N.x + vp.y * N.z, vp.x * N.y + vp.y * N.w);
    return r;
}
