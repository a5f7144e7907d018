// The ways of visiting the handles for one evaluation, mls_eval(v): every handle in a loop,
// unrolled at constant indices (MLS_UNROLL), or only those in reach through a spatial grid of
// bins (MLS_BINS). Every pass that needs f, M or T includes this file.
//
// Defines (besides those of core.glsl):
//   MLS_UNROLL          0, or 16 / 64: at most that many handles, read at constant indices
//   MLS_BINS            0 or 1: handles sorted into bins, visit only those in reach (below)
//   MLS_REACH_GAUSSIAN  0 or 1 (with MLS_BINS): the weight never reaches 0 and is cut where
//                       its tail is negligible (glmls.core.weights, support "gaussian")
//   MLS_GAUSSIAN_TOLERANCE  that cut's tolerance, glmls.core.weights.GAUSSIAN_TOLERANCE
//   MLS_SEGMENTS        0 or 1: there are segment handles too (mls/segments.glsl); with
//                       MLS_BINS a point visits the segments listed in its own bin, which
//                       lists every segment whose reach touches the bin (the gaussian's
//                       cut reaching farther, far from every handle: every segment)
#include "mls/core.glsl"
#if MLS_SEGMENTS
#include "mls/segments.glsl"
#endif

// MLS_EACH(F): F(i, use) for every handle i of the plain path (n = mls_handle_count()). Where
// MLS_UNROLL (16 or 64) slots are unrolled by the preprocessor, i is a constant: llvmpipe then
// loads a handle once for all lanes instead of gathering it per lane (1.5x faster), and slots
// from n on are zero and given no weight (use: i < n). Past 64 handles, a loop of blocks
// (mls/handles.glsl's MLS_BLOCKS: llvmpipe's limit on loop iterations).
#define MLS_SLOT(F, i) F(i, (i) < n)
#define MLS_R4(F, i) MLS_SLOT(F, i) MLS_SLOT(F, i + 1) MLS_SLOT(F, i + 2) MLS_SLOT(F, i + 3)
#define MLS_R16(F, i) MLS_R4(F, i) MLS_R4(F, i + 4) MLS_R4(F, i + 8) MLS_R4(F, i + 12)
#define MLS_R64(F, i) MLS_R16(F, i) MLS_R16(F, i + 16) MLS_R16(F, i + 32) MLS_R16(F, i + 48)
#if MLS_UNROLL == 16
#define MLS_EACH(F) MLS_R16(F, 0)
#elif MLS_UNROLL == 64
#define MLS_EACH(F) MLS_R64(F, 0)
#elif MLS_UNROLL
#error "MLS_UNROLL: 0, 16 or 64"
#else
#define MLS_EACH(F) MLS_BLOCKS(F, n)
#endif
#define MLS_NEAR(i, use) mls_nearest_index(d2min, d2next, nearest, next, v, mls_handle(i).xy, i, use);
#define MLS_ACC(i, use) mls_accumulate(a, mls_handle(i), use);
#define MLS_NEAR_PAIR(i, use) mls_nearest_pair(d2min, d2next, nearest, next, v0, v1, i, use);
#define MLS_ACC_PAIR(i, use) mls_accumulate_pair(a0, a1, i, use);
#define MLS_NEAR_ADD(i, use) mls_nearest_add(near, mls_handle(i), v, use);
#define MLS_FAR(i, use) mls_nearest_far(near.d2far, v, i, use);

#if MLS_BINS
// Handles sorted by the bins of a square grid (glmls/engine/bins.py): bin b's handles are
// mls_handle(mls_bin_start[b]) .. mls_handle(mls_bin_start[b + 1] - 1), bins row-major.
layout(std430, binding = BIND_BIN_STARTS) readonly buffer MLSBinStarts {
    int mls_bin_start[];
};
uniform vec2 u_bin_origin;   // lower corner of bin (0, 0), scaled
uniform float u_bin_size;    // bin side, scaled
uniform ivec2 u_bin_dims;    // bins per row, rows
uniform float u_bin_reach;   // R (compact weights) or R sqrt(cut) (gaussian), scaled
uniform float u_bin_near;    // half-side of the first square searched for the nearest, scaled
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
    bool snapped = mls_snaps(near);
    float side2 = side * side;
    bool certain = near.d2min <= side2 && (!snapped || near.d2far <= side2);
#if MLS_REACH_GAUSSIAN
    // the gaussian cut is measured against the nearest handles apart from the nearest's place
    certain = certain && near.d2next <= side2;
#endif
    return certain;
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

#if MLS_REACH_GAUSSIAN
// W1, a lower bound of the total weight at a.v of the handles apart from the nearest one's
// place, relative to the nearest of them (at squared distance g, weight 1), for the gaussian
// cut (glmls/engine/bins.py): the weights of those in the bins lo..hi that every cut keeps
// (weight >= tolerance), and at least the nearest apart's, 1. Those handles, not the nearest
// (whose own moments about itself are 0), make the central moments that decide M.
float mls_weight_bound(MLSAccum a, float g, ivec2 lo, ivec2 hi) {
    float w1 = 0.0;
    float inv_g = 1.0 / g;
    for (int y = lo.y; y <= hi.y; ++y) {
        ivec2 run = mls_bin_run(y, lo.x, hi.x);
        for (int i = run.x; i < run.y; ++i) {
            vec2 dp = mls_handle(i).xy - a.v;
            float d2 = dot(dp, dp);
            float w = d2 >= g ? mls_weight(d2, g, inv_g, a.sigma) : 0.0;
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

#if MLS_SEGMENTS
#if MLS_BINS
uniform int u_bin_segment_starts;   // where the segment runs start in mls_bin_start
uniform int u_bin_segment_list;     // where the segment indices start in mls_bin_start

// The segments v visits: those listed in its bin (the grid covers every segment's reach).
ivec2 mls_segment_run(vec2 v) {
    vec2 cell = clamp(floor((v - u_bin_origin) / u_bin_size), vec2(0.0), vec2(u_bin_dims - 1));
    int b = int(cell.y) * u_bin_dims.x + int(cell.x);
    return ivec2(mls_bin_start[u_bin_segment_starts + b],
                 mls_bin_start[u_bin_segment_starts + b + 1]);
}

int mls_segment_at(int i) {
    return mls_bin_start[u_bin_segment_list + i];
}
#else
ivec2 mls_segment_run(vec2 v) {
    return ivec2(0, u_segment_count);
}

int mls_segment_at(int i) {
    return i;
}
#endif

void mls_nearest_segments(inout MLSNearest near, vec2 v) {
    ivec2 run = mls_segment_run(v);
    for (int i = run.x; i < run.y; ++i) {
        mls_nearest_add_segment(near, mls_segment(mls_segment_at(i)), v);
    }
}

void mls_accumulate_segments(inout MLSAccum a) {
    ivec2 run = mls_segment_run(a.v);
    for (int i = run.x; i < run.y; ++i) {
        mls_accumulate_segment(a, mls_segment(mls_segment_at(i)));
    }
}

#if MLS_BINS && MLS_REACH_GAUSSIAN
// Every segment, listed in v's bin or not: where the gaussian's cut, relative to the nearest
// handles, reaches farther than the bins list segments for (mls_eval).
void mls_nearest_every_segment(inout MLSNearest near, vec2 v) {
    for (int s = 0; s < u_segment_count; ++s) {
        mls_nearest_add_segment(near, mls_segment(s), v);
    }
}

void mls_accumulate_every_segment(inout MLSAccum a) {
    for (int s = 0; s < u_segment_count; ++s) {
        mls_accumulate_segment(a, mls_segment(s));
    }
}
#endif
#endif

#include "common/loops.glsl"

// Whether every evaluation of f so far walked all its handles (common/loops.glsl): a pass
// that makes more evaluations than a CPU renderer's cap on loop iterations may leave whole
// trusts only those made before this turns false.
bool mls_loops_whole() {
    return loops_whole(2 + min(mls_handle_count(), 0));
}

#if MLS_TRANSFORM == 0
#include "mls/full.glsl"
#else
// only affine takes the float64 pass: r as mls_finish gave it
#define mls_full_all(a, r, every) (r)
#define mls_full_bins(a, r, radius, lo, hi, every) (r)
#endif

// The plain evaluation's nearest pass (every handle, in storage order) tracks only the
// nearest's distance and index, and the handle is read once after it; the nearest beyond the
// snapping distance is looked for in a second pass only where v snaps, which a work group
// away from the handles skips. ``use``: false for an empty slot (MLS_UNROLL).
// With the gaussian it tracks the least squared distance above the nearest's too (d2next,
// see mls_gaussian_offset), and that handle's index (next: MLSNearest's pnext).
void mls_nearest_index(inout float d2min, inout float d2next, inout int nearest, inout int next,
                       vec2 v, vec2 p, int i, bool use) {
    vec2 dp = p - v;
    float d2 = use ? dot(dp, dp) : 3.0e38;
#if MLS_REACH_GAUSSIAN
    next = d2 < d2min ? nearest : (d2 > d2min && d2 < d2next ? i : next);
#endif
    nearest = d2 < d2min ? i : nearest;
    mls_track_next(d2next, d2min, d2);
    d2min = min(d2min, d2);
}

void mls_nearest_far(inout float d2far, vec2 v, int i, bool use) {
    vec2 dp = mls_handle(i).xy - v;
    float d2 = use ? dot(dp, dp) : 3.0e38;
    d2far = min(d2far, d2 > u_hit2 ? d2 : 3.0e38);
}

// Two points' steps with the handle read once (mls_eval_pair).
void mls_nearest_pair(inout vec2 d2min, inout vec2 d2next, inout ivec2 nearest, inout ivec2 next,
                      vec2 v0, vec2 v1, int i, bool use) {
    vec2 p = mls_handle(i).xy;
    mls_nearest_index(d2min.x, d2next.x, nearest.x, next.x, v0, p, i, use);
    mls_nearest_index(d2min.y, d2next.y, nearest.y, next.y, v1, p, i, use);
}

void mls_accumulate_pair(inout MLSAccum a0, inout MLSAccum a1, int i, bool use) {
    vec4 h = mls_handle(i);
    mls_accumulate(a0, h, use);
    mls_accumulate(a1, h, use);
}

// Both passes over every handle, in storage order (where the bins give up).
void mls_nearest_all(inout MLSNearest near, vec2 v) {
    int n = mls_handle_count();
    MLS_BLOCKS(MLS_NEAR_ADD, n)
}

void mls_accumulate_all(inout MLSAccum a) {
    int n = mls_handle_count();
    MLS_BLOCKS(MLS_ACC, n)
}

#if !MLS_BINS
// The plain path's record of the nearest handle once its index is known, with the nearest
// beyond the snapping distance where v snaps.
MLSNearest mls_nearest_found(float d2min, float d2next, int nearest, int next, vec2 v, int n) {
    MLSNearest near = mls_nearest_begin();
    near.d2min = d2min;
#if MLS_TRACK_NEXT
    near.d2next = d2next;
#endif
#if MLS_REACH_GAUSSIAN
    near.pnext = n > 0 ? mls_handle(next).xy : vec2(0.0);
#endif
    near.h = n > 0 ? mls_handle(nearest) : vec4(0.0);
#if MLS_SEGMENTS
    mls_nearest_segments(near, v);
#endif
    if (mls_snaps(near)) {
        // A loop even where the other passes are unrolled: llvmpipe runs a branch's body
        // under a mask whether or not a lane takes it, but leaves a loop as soon as no
        // lane is in it, and lanes rarely snap (64 unrolled slots here cost ~5 % of the
        // whole pass at 64 handles; the loop's per-lane reads only where one snaps).
        MLS_BLOCKS(MLS_FAR, n)
    }
    return near;
}

MLSResult mls_end(MLSAccum a) {
#if MLS_SEGMENTS
    mls_accumulate_segments(a);
#endif
    return mls_full_all(a, mls_finish(a), false);
}
#endif

MLSResult mls_eval(vec2 v) {
#if MLS_BINS
    // Pass 1 finds the nearest handle, first in the bins within u_bin_near of v (about a
    // handle spacing, glmls/engine/bins.py), then within reach: a compact weight is 0
    // beyond R, so if none is there no handle reaches v. The gaussian goes on in squares of
    // twice the side until the nearest, and the nearest apart from its place, are certain.
    // Where a square or the disc spans more bin rows than there are handles (a few handles
    // far apart), walking its rows costs more than visiting every handle: that is done. On
    // a CPU renderer that caps an invocation's loop iterations (LOOP_CAP, common/loops.glsl)
    // so it is where the square or the disc reaches past twice the bins' reach (a gaussian
    // point far from every handle, or whose nearest handle is far from the others): the
    // bins, one handle a loop iteration, would walk most handles, more iterations than the
    // cap allows where there are thousands; every handle, sixteen an iteration, takes n / 16.
    int n = mls_handle_count();
    ivec2 lo, hi;
    MLSNearest near = mls_nearest_begin();
#if MLS_SEGMENTS
    mls_nearest_segments(near, v);
#endif
    float side = u_bin_near;
    mls_bin_range(v, side, lo, hi);
    mls_nearest_bins(near, v, lo, hi);
    ivec2 lo1 = lo, hi1 = hi;
    for (int k = 0; k < 40 && !mls_nearest_certain(near, side, lo, hi); ++k) {
#if !MLS_REACH_GAUSSIAN
        if (side >= u_bin_reach) {
            break;
        }
#endif
#if MLS_REACH_GAUSSIAN
        // the nearest known, the next distance is near it (a handle spacing): the square
        // doubles, where the nearest's search goes to the cut's reach at once
        side = near.d2min <= side * side ? 2.0 * side : max(2.0 * side, u_bin_reach);
#else
        side = max(2.0 * side, u_bin_reach);
#endif
        mls_bin_range(v, side, lo, hi);
        if (hi.y - lo.y >= n || (LOOP_CAP != 0 && side > 2.0 * u_bin_reach)) {
            mls_nearest_all(near, v);
            break;
        }
        mls_nearest_bins(near, v, lo, hi);   // the handles seen twice change no minimum
    }
    MLSAccum a = mls_begin(v, near);
    float r = u_bin_reach;
    bool every_segment = false;
#if MLS_REACH_GAUSSIAN
    // gaussian: weights below tau W1 / N of the nearest apart from the nearest one's place
    // are left out (glmls/engine/bins.py); with no handle apart, those of the nearest
    float g = mls_gaussian_offset(a.m, near.d2next);
    float cut = u_bin_cut - log(mls_weight_bound(a, g, lo1, hi1));
    r = sqrt(g + cut * u_radius * u_radius);
#if MLS_SEGMENTS
    // A bin lists the segments within u_bin_reach of it. Where the cut reaches farther (far
    // from every handle: the cut is relative to the nearest ones), segments it does not
    // list count, and may be the nearest: every segment, the nearest and the cut again.
    // Within u_bin_reach the listed ones hold the nearest two, the unlisted being farther.
    every_segment = r > u_bin_reach;
    if (every_segment) {
        mls_nearest_every_segment(near, v);   // the listed ones seen twice change no minimum
        a = mls_begin(v, near);
        g = mls_gaussian_offset(a.m, near.d2next);
        cut = u_bin_cut - log(mls_weight_bound(a, g, lo1, hi1));
        r = sqrt(g + cut * u_radius * u_radius);
    }
#endif
#endif
    // Pass 2 over the disc of radius r, row by row (or over every handle, which adds
    // only weights that are zero or within the cut's tolerance).
#if MLS_SEGMENTS && MLS_REACH_GAUSSIAN
    if (every_segment) {
        mls_accumulate_every_segment(a);
    } else {
        mls_accumulate_segments(a);
    }
#elif MLS_SEGMENTS
    mls_accumulate_segments(a);
#endif
    mls_bin_range(v, r, lo, hi);
    if (hi.y - lo.y >= n || (LOOP_CAP != 0 && r > 2.0 * u_bin_reach)) {
        mls_accumulate_all(a);
        return mls_full_all(a, mls_finish(a), every_segment);
    }
    for (int y = lo.y; y <= hi.y; ++y) {
        ivec2 columns = mls_bin_chord(v, r, y, lo, hi);
        ivec2 run = mls_bin_run(y, columns.x, columns.y);
        for (int i = run.x; i < run.y; ++i) {
            mls_accumulate(a, mls_handle(i), true);
        }
    }
    return mls_full_bins(a, mls_finish(a), r, lo, hi, every_segment);
#else
    int n = mls_handle_count();
    float d2min = 3.0e38;
    float d2next = 3.0e38;
    int nearest = 0;
    int next = 0;
    MLS_EACH(MLS_NEAR)
    MLSAccum a = mls_begin(v, mls_nearest_found(d2min, d2next, nearest, next, v, n));
    MLS_EACH(MLS_ACC)
    return mls_end(a);
#endif
}

// f at two points, as two calls of mls_eval would give it, bit for bit. The plain path reads
// each handle once for both: on llvmpipe a handle read at a constant index is a load and a
// broadcast to the lanes (MLS_UNROLL), in a loop a load per lane; the pass measured ~1.1x
// faster at 16-64 handles, 1.3x at 256.
void mls_eval_pair(vec2 v0, vec2 v1, out MLSResult r0, out MLSResult r1) {
#if MLS_BINS
    r0 = mls_eval(v0);
    r1 = mls_eval(v1);
#else
    int n = mls_handle_count();
    vec2 d2min = vec2(3.0e38);
    vec2 d2next = vec2(3.0e38);
    ivec2 nearest = ivec2(0);
    ivec2 next = ivec2(0);
    MLS_EACH(MLS_NEAR_PAIR)
    MLSAccum a0 = mls_begin(v0, mls_nearest_found(d2min.x, d2next.x, nearest.x, next.x, v0, n));
    MLSAccum a1 = mls_begin(v1, mls_nearest_found(d2min.y, d2next.y, nearest.y, next.y, v1, n));
    MLS_EACH(MLS_ACC_PAIR)
    r0 = mls_end(a0);
    r1 = mls_end(a1);
#endif
}
