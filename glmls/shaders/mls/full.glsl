// Affine MLS in float64 where A is nearly singular (MLS_TRANSFORM 0; included by
// mls/visit.glsl once the ways of visiting the handles are defined).
//
// Why: where the weighted handles in reach lie near one line, A's small eigenvalue e2 is a
// small share of its trace, and N = A^-1 D magnifies the rounding of the float32 moments
// (~6e-8 of each sum, different at every point) by trace / e2. With the ridge (below a share
// of 1e-3, mls_finish) that is up to 1e3: M off by ~1e-4 and f by ~1e-4 |v - p*|, a tenth
// of a pixel 700 px from three handles 34 times longer than wide, and rough from point to
// point. So the points whose float32 share lies below MLS_FULL_SHARE (mls_finish sets
// mls_full_needed) sum their moments again in float64, from the same float32 handles and
// weights (their differences and products are exact in float64, and a weight's rounding
// scales its handle's terms alike), and solve in float64, as glmls.reference does and as the
// 3D solve does (mls3/solve_full.glsl). Segment handles add their float32 moments.
//
// Each pass below is a loop that a lane not needing it does not enter: llvmpipe (and a GPU's
// warp) runs an if's body under a mask for every lane, but leaves a loop as soon as no lane
// is in it, and most points need no second pass.

struct MLSSums64 {
    double W;
    dvec2 P;
    dvec2 E;
    dvec3 PP;   // (xx, xy, yy)
    dvec4 PE;   // (11, 12, 21, 22)
};

MLSSums64 mls_sums64_begin() {
    MLSSums64 s;
    s.W = 0.0lf;
    s.P = dvec2(0.0lf);
    s.E = dvec2(0.0lf);
    s.PP = dvec3(0.0lf);
    s.PE = dvec4(0.0lf);
    return s;
}

// mls_accumulate's terms in float64: the same float32 weight, the differences about the
// nearest handle exact.
void mls_accumulate64(inout MLSSums64 s, MLSAccum a, vec4 h, bool use) {
    vec2 dp = h.xy - a.v;
    float d2 = dot(dp, dp);
    double w = double(use ? mls_handle_weight(a, h.xy, d2) : 0.0);
    dvec2 P = dvec2(h.xy) - dvec2(a.o.xy);
    dvec2 E = (dvec2(h.zw) - dvec2(h.xy)) - (dvec2(a.o.zw) - dvec2(a.o.xy));
    dvec2 wP = w * P;
    s.W += w;
    s.P += wP;
    s.E += w * E;
    s.PP += dvec3(wP.x * P.x, wP.x * P.y, wP.y * P.y);
    s.PE += dvec4(wP.x * E.x, wP.x * E.y, wP.y * E.x, wP.y * E.y);
}
#define MLS_ACC64(i, use) mls_accumulate64(s, a, mls_handle(i), use);

#if MLS_SEGMENTS
// a's segment handles' float32 moments (``every``: every segment, not only those v's bin
// lists; see mls_eval), added to the float64 sums
void mls_segments64(inout MLSSums64 s, MLSAccum a, bool every) {
    MLSAccum t = a;
    t.W = 0.0;
    t.P = vec2(0.0);
    t.E = vec2(0.0);
    t.PP = vec3(0.0);
    t.PE = vec4(0.0);
#if MLS_BINS && MLS_REACH_GAUSSIAN
    if (every) {
        mls_accumulate_every_segment(t);
    } else {
        mls_accumulate_segments(t);
    }
#else
    mls_accumulate_segments(t);
#endif
    s.W += double(t.W);
    s.P += dvec2(t.P);
    s.E += dvec2(t.E);
    s.PP += dvec3(t.PP);
    s.PE += dvec4(t.PE);
}
#endif

// mls_finish's affine branch (the ridge toward the similarity solution included) in float64.
MLSResult mls_finish64(MLSAccum a, MLSSums64 s) {
    dvec2 pst = dvec2(a.o.xy);
    dvec2 est = dvec2(a.o.zw) - dvec2(a.o.xy);
    if (!a.hit) {
        dvec2 dp = s.P / s.W;
        dvec2 de = s.E / s.W;
        pst += dp;
        est += de;
        s.PP -= dvec3(s.P.x * dp.x, s.P.x * dp.y, s.P.y * dp.y);
        s.PE -= dvec4(s.P.x * de.x, s.P.x * de.y, s.P.y * de.x, s.P.y * de.y);
    }
    double mu = s.PP.x + s.PP.z;
    dvec4 N = dvec4(0.0lf);   // coincident sources: a translation (mls_rotation_scale)
    if (mu > 1e-13lf * double(mls_yardstick(a.yard))) {
        dvec3 An = s.PP / mu;
        dvec4 Dn = s.PE / mu;
        double c = Dn.x + Dn.w;
        double b = Dn.y - Dn.z;
        dvec4 sim = dvec4(c, b, -b, c);
        const double share = 1e-3lf;   // MLS_DEGENERATE_SHARE, exactly
        double det = An.x * An.z - An.y * An.y;
        double gap = sqrt((An.x - An.z) * (An.x - An.z) + 4.0lf * An.y * An.y);
        double e1 = 0.5lf * (1.0lf + gap);
        double e2 = max(det, 0.0lf) / e1;
        double x = 1.0lf - e2 / share;
        dvec3 G = x > 0.0lf ? (share * x * x / gap) * dvec3(e1 - An.x, -An.y, e1 - An.z)
                            : dvec3(0.0lf);
        dvec3 L = An + G;
        dvec4 R = Dn + dvec4(G.x * sim.x + G.y * sim.z, G.x * sim.y + G.y * sim.w,
                             G.y * sim.x + G.z * sim.z, G.y * sim.y + G.z * sim.w);
        double detL = L.x * L.z - L.y * L.y;
        N = sim;
        if (detL > 0.0lf) {
            dvec2 r0 = dvec2(L.z, -L.y) / detL;
            dvec2 r1 = dvec2(-L.y, L.x) / detL;
            N = dvec4(r0.x * R.x + r0.y * R.z, r0.x * R.y + r0.y * R.w,
                      r1.x * R.x + r1.y * R.z, r1.x * R.y + r1.y * R.w);
        }
    }
    dvec2 vp = dvec2(a.v) - pst;
    MLSResult r;
    r.M = vec4(N) + vec4(1.0, 0.0, 0.0, 1.0);
    r.d = vec2(est + dvec2(vp.x * N.x + vp.y * N.z, vp.x * N.y + vp.y * N.w));
    r.f = a.v + r.d;
    return r;
}

// The points' sums s of their handles, with their segments', solved: r replaced where
// ``need`` (a loop, see above)
MLSResult mls_full_end(MLSAccum a, MLSSums64 s, MLSResult r, bool need, bool every) {
    for (int once = 0; once < (need ? 1 : 0); ++once) {
#if MLS_SEGMENTS
        mls_segments64(s, a, every);
#endif
        r = mls_finish64(a, s);
    }
    return r;
}

// r (mls_finish's result for a) again in float64 where mls_finish asked for it, over every
// handle (the plain path's visit)
MLSResult mls_full_all(MLSAccum a, MLSResult r, bool every) {
    bool need = mls_full_needed;
    int n = mls_handle_count();
    MLSSums64 s = mls_sums64_begin();
    for (int mls_block = 0; mls_block < (need ? n : 0); mls_block += 4) {
        MLS_BLOCK4(MLS_ACC64, mls_block, n)
    }
    return mls_full_end(a, s, r, need, every);
}

#if MLS_BINS
// mls_full_all over the handles in the disc of radius ``radius`` about a.v (bins lo..hi,
// mls_bin_range's), row by row of bins as mls_eval's second pass visits them
MLSResult mls_full_bins(MLSAccum a, MLSResult r, float radius, ivec2 lo, ivec2 hi, bool every) {
    bool need = mls_full_needed;
    MLSSums64 s = mls_sums64_begin();
    for (int y = lo.y; y <= (need ? hi.y : lo.y - 1); ++y) {
        ivec2 columns = mls_bin_chord(a.v, radius, y, lo, hi);
        ivec2 run = mls_bin_run(y, columns.x, columns.y);
        for (int i = run.x; i < run.y; ++i) {
            mls_accumulate64(s, a, mls_handle(i), true);
        }
    }
    return mls_full_end(a, s, r, need, every);
}
#endif
