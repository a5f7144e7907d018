// Newton's method on f: the source point s with f(s) = u (scaled coordinates), from a first
// guess. The Jacobian is taken by forward differences: the MLS Jacobian is not M (M varies
// with v). Needs mls/visit.glsl (mls_eval), u_scale (warp/frame.glsl) and WARP_NEWTON_STEPS,
// the most steps.

// The length (pixels) of which the differences' steps are the fixed shares: 1 for an image's
// pixels, less for f's inverse at points with handles in a small box
// (glmls.imaging.inverse.length_unit), so that handles in metres get the inverse that the
// same handles in millimetres do. WARP_UNIT_VARIES 1: a pass over many images sets it per
// image (a global, not a uniform).
#ifndef WARP_UNIT_VARIES
#define WARP_UNIT_VARIES 0
#endif
#if WARP_UNIT_VARIES
float u_newton_unit = 1.0;   // the pass sets it before any Newton step
#else
uniform float u_newton_unit;
#endif

// warp_accept where f magnifies lengths ``stretch`` times at s: s's own float32 steps, times
// the stretch, are steps of f(s) (a thousandfold magnification makes one a tenth of a pixel).
float warp_accept_at(float accept, float steps, vec2 u, vec2 s, float stretch) {
    float far_u = max(1.0, max(abs(u.x), abs(u.y)));
    float far_s = max(1.0, max(abs(s.x), abs(s.y))) * max(stretch, 1.0);
    return max(accept / u_scale, steps * 1.1920929e-7 * max(far_u, far_s));
}

// The residual (scaled) up to which s counts as a preimage of u (scaled): ``accept`` (pixels),
// or ``steps`` float32 steps of the larger coordinate of u and s where that is more: far from
// the scaling's centre float32 cannot tell f(s) from u to a twentieth of a pixel
// (glmls.imaging.inverse.accept_residual).
float warp_accept(float accept, float steps, vec2 u, vec2 s) {
    return warp_accept_at(accept, steps, u, s, 1.0);
}

// The differences' step (scaled): a thirty-second of the length unit.
float warp_damped_h() {
    return 0.03125 * u_newton_unit / u_scale;
}

// The least step of a difference at s, per unit of s's largest scaled coordinate: far from
// the scaling's centre a step of a fixed length is a few of float32's steps of s, or none
// (at 6e5 pixels of handles in a box of a pixel), and the difference is rounding; at
// 2^7 float32 steps the rounding stays below 1 % of the Jacobian, enough to steer Newton.
const float WARP_STEP_FLOOR = 1.52587890625e-5;   // 2^-16

// A difference's step at s (scaled): ``h``, or WARP_STEP_FLOOR of s's largest coordinate.
float warp_step_at(float h, vec2 s) {
    vec2 a = abs(s);
    return max(h, WARP_STEP_FLOOR * max(a.x, a.y));
}

// The longer column of a Jacobian (df/dx, df/dy): warp_accepted's hint.
float warp_hint(vec2 jx, vec2 jy) {
    return max(length(jx), length(jy));
}

// The most evaluations of f one start of damped Newton makes: f at the start, three a step
// (two differences and the step), and the halvings.
const int WARP_DAMPED_EVALUATIONS = 1 + 4 * WARP_NEWTON_STEPS;

// How many evaluations of f an invocation of a Newton pass may make, at most ``most``: all of
// them on a GPU; within a CPU renderer's cap on an invocation's loop iterations (llvmpipe:
// 65,535 over all loops, 4 SCAN_PIECE_PIXELS; it then ends the loops as if done, counting
// for all the lanes of a vector together, so that a pixel's result would depend on its lane
// mates, and f would leave handles out) as many as fit with one more (an identity check
// after), 1,024 iterations left to the loops around: an evaluation walks the handles up to
// three times (the nearest, the snapped point's normalisation, the moments), sixteen handles
// a loop iteration, one a segment, and is one iteration of the Newton loop. With bins a walk
// visits only the handles of the bins near the point, a count not known here: all, each
// Newton loop keeping only the evaluations the cap left whole (mls_loops_whole).
int warp_evaluations(int most) {
#if SCAN_PIECE_PIXELS == 0 || MLS_BINS
    return most;
#else
#if MLS_UNROLL
    int per_walk = 2;   // unrolled: only the snapped point's normalisation loops
#else
    int per_walk = (mls_handle_count() + 15) / 16 + 2;
#endif
#if MLS_SEGMENTS
    per_walk += u_segment_count + 1;
#endif
    return clamp((4 * SCAN_PIECE_PIXELS - 1024) / (3 * per_walk + 1) - 1, 1, most);
#endif
}

#include "common/stretch.glsl"

// The evaluations of f warp_accepted may make (common/stretch.glsl's, in 2D).
const int WARP_ACCEPT_EVALUATIONS = 9;

// Whether s counts as a preimage of u, ``residual`` = |f(s) - u| (scaled): within warp_accept,
// or, where f magnifies, within warp_accept_at f's stretch at s (common/stretch.glsl, steps
// of warp_damped_h). ``hint``: the longer column of the last Newton step's Jacobian (forward
// differences; 1 where none was taken): a residual that twice the hint's stretch would not
// accept is refused unmeasured, the pixels that f leaves uncovered among them. The
// measure's evaluations run in one loop that a point needing no measure skips (a CPU
// renderer runs a loop as long as its slowest lane, where it would run a branch's code for
// every lane whatever its mask), and only where a CPU renderer's cap on an invocation's
// loop iterations leaves room for them past Newton's (warp_evaluations).
bool warp_accepted(float accept, float steps, vec2 u, vec2 s, float residual, float hint) {
    const int most = 1 + 3 * WARP_NEWTON_STEPS + WARP_ACCEPT_EVALUATIONS;
    float plain = warp_accept(accept, steps, u, s);
    bool measure = !(residual <= plain) &&
                   residual <= warp_accept_at(accept, steps, u, s, 2.0 * hint) &&
                   warp_evaluations(most) == most;
    float h = warp_step_at(warp_damped_h(), s);
    StretchMeasure m = stretch_begin(2);
    int count = measure ? WARP_ACCEPT_EVALUATIONS : 0;
    for (int k = 0; k < count; ++k) {
        vec2 f = mls_eval(stretch_point(vec3(s, 0.0), k, h).xy).f;
        stretch_take(m, k, vec3(f, 0.0));
    }
    if (!measure || !mls_loops_whole()) {   // a capped walk measures no stretch
        return residual <= plain;
    }
    return residual <= warp_accept_at(accept, steps, u, s, stretch_of(m, h));
}

// The last iterate from ``s``: stops once |f(s) - u| <= tolerance (scaled), after
// WARP_NEWTON_STEPS steps (fewer where warp_evaluations allows fewer), or where f is singular
// (a fold's edge); ``residual`` is its |f(s) - u|, scaled, ``hint`` warp_accepted's. A step
// goes at most ``max_step`` (scaled): far from the solution, Newton's step may overshoot.
vec2 warp_newton(vec2 s, vec2 u, float tolerance, float max_step, out float residual,
                 out float hint) {
    float h = 0.25 * u_newton_unit / u_scale;   // a quarter pixel: float32 noise in f ~1e-4 of it
    // three evaluations a step (f and its two differences), and one for the last f
    int steps = (warp_evaluations(1 + 3 * WARP_NEWTON_STEPS) - 1) / 3;
    residual = 0.0;
    hint = 1.0;
    vec2 whole_s = s;        // the last iterate whose f a CPU renderer's cap left whole,
    float whole_r = 3.0e38;  // and its residual (none yet: none accepted)
    for (int k = 0; ; ++k) {
        vec2 r = mls_eval(s).f - u;
        residual = length(r);
        if (!mls_loops_whole()) {
            s = whole_s;   // f left handles out: the iterate before, whose f had them all
            residual = whole_r;
            break;
        }
        whole_s = s;
        whole_r = residual;
        if (residual <= tolerance || k >= steps) {
            break;
        }
        vec2 fs = r + u;
        vec2 at = s + vec2(warp_step_at(h, s));
        vec2 jx = (mls_eval(vec2(at.x, s.y)).f - fs) / (at.x - s.x);   // df/dx
        vec2 jy = (mls_eval(vec2(s.x, at.y)).f - fs) / (at.y - s.y);   // df/dy
        hint = warp_hint(jx, jy);
        float det = jx.x * jy.y - jy.x * jx.y;
        if (!(abs(det) > 1e-12)) {
            break;   // f is singular here (a fold's edge): keep the best point so far
        }
        vec2 step = vec2(jy.y * r.x - jy.x * r.y, jx.x * r.y - jx.y * r.x) / det;
        float len = length(step);
        s -= len > max_step ? step * (max_step / len) : step;
    }
    return s;
}

// Damped Newton, as warp_newton, for a point where it ended above the residual accepted (a
// dip of |f(s) - u| that is no preimage, next to a fold or a handle, where whole steps
// cycle): a step that raises the residual is halved, up to WARP_NEWTON_STEPS halvings in all,
// and taken where none brings it down (Newton may have to climb out of a dip); the Jacobian's
// difference is a thirty-second of a pixel (f curves fast there; float32's noise is ~1e-3 of
// it, and the steps' directions still hold). The best iterate is kept. Only the second
// passes run it (warp/inverse.comp.glsl's WARP_RESCUE, the inverse at points' second
// dispatch), over the few points the first left.
//
// It runs as a machine that takes one evaluation of f at a time (warp_damped_point, then
// warp_damped_take), so that the caller's one flat loop makes one evaluation an iteration
// over all its starts: a CPU renderer runs a loop for as long as its slowest lane, and nested
// loops (the halvings inside the steps inside the starts) would add up the slowest lane of
// each, where one loop costs only the slowest lane's own count (warp_evaluations).
const int WARP_DAMPED_START = 0;   // next: f at the start
const int WARP_DAMPED_DX = 1;      // next: f a difference along x from s
const int WARP_DAMPED_DY = 2;      // next: f a difference along y from s
const int WARP_DAMPED_TRY = 3;     // next: f at s - step
const int WARP_DAMPED_DONE = 4;    // converged, out of steps, or f singular at s

struct WarpDamped {
    vec2 s;          // the iterate
    vec2 r;          // f(s) - u
    float residual;  // |r|
    vec2 best;       // the iterate of the least residual so far
    float least;
    vec2 jx;         // df/dx, between the two differences
    vec2 step;       // the step tried, halved while it raises the residual
    int phase;       // WARP_DAMPED_*
    int steps;       // the steps taken
    int halvings;
};

// Damped Newton from ``start``: its first evaluation is f at start.
WarpDamped warp_damped_begin(vec2 start) {
    WarpDamped d;
    d.s = start;
    d.r = vec2(0.0);
    d.residual = 0.0;
    d.best = start;
    d.least = 0.0;
    d.jx = vec2(0.0);
    d.step = vec2(0.0);
    d.phase = WARP_DAMPED_START;
    d.steps = 0;
    d.halvings = 0;
    return d;
}

// Where d needs f next.
vec2 warp_damped_point(WarpDamped d, float h) {
    vec2 at = d.s + vec2(warp_step_at(h, d.s));   // the steps float32 takes (warp_damped_take)
    return d.phase == WARP_DAMPED_DX   ? vec2(at.x, d.s.y)
         : d.phase == WARP_DAMPED_DY   ? vec2(d.s.x, at.y)
         : d.phase == WARP_DAMPED_TRY  ? d.s - d.step
                                       : d.s;
}

// d advanced by ``f``, f at warp_damped_point(d, h); never left at WARP_DAMPED_START, so that
// best and least hold a result after the first call.
void warp_damped_take(inout WarpDamped d, vec2 f, vec2 u, float h, float tolerance,
                      float max_step) {
    if (d.phase == WARP_DAMPED_START) {
        d.r = f - u;
        d.residual = length(d.r);
        d.best = d.s;
        d.least = d.residual;
        d.phase = d.residual > tolerance && WARP_NEWTON_STEPS > 0 ? WARP_DAMPED_DX
                                                                  : WARP_DAMPED_DONE;
    } else if (d.phase == WARP_DAMPED_DX) {
        vec2 at = d.s + vec2(warp_step_at(h, d.s));
        d.jx = (f - (d.r + u)) / (at.x - d.s.x);   // df/dx
        d.phase = WARP_DAMPED_DY;
    } else if (d.phase == WARP_DAMPED_DY) {
        vec2 jx = d.jx;
        vec2 at = d.s + vec2(warp_step_at(h, d.s));
        vec2 jy = (f - (d.r + u)) / (at.y - d.s.y);   // df/dy
        float det = jx.x * jy.y - jy.x * jx.y;
        vec2 step = vec2(jy.y * d.r.x - jy.x * d.r.y, jx.x * d.r.y - jx.y * d.r.x) / det;
        float len = length(step);
        d.step = step * (len > max_step ? max_step / len : 1.0);
        // f singular here (a fold's edge): the best point so far stays
        d.phase = abs(det) > 1e-12 ? WARP_DAMPED_TRY : WARP_DAMPED_DONE;
    } else if (d.phase == WARP_DAMPED_TRY) {
        vec2 rt = f - u;
        if (length(rt) > d.residual && d.halvings < WARP_NEWTON_STEPS) {
            d.step *= 0.5;
            ++d.halvings;
        } else {
            d.s -= d.step;
            d.r = rt;
            d.residual = length(rt);
            d.best = d.residual < d.least ? d.s : d.best;
            d.least = min(d.residual, d.least);
            ++d.steps;
            d.phase = d.steps < WARP_NEWTON_STEPS && d.residual > tolerance ? WARP_DAMPED_DX
                                                                            : WARP_DAMPED_DONE;
        }
    }
}

// The preimage of u from the first pass's point ``s`` (its residual ``residual``, scaled; a
// NaN counts as none): damped Newton from s, then from u itself, the least residual kept, in
// one flat loop (warp_damped_take).
void warp_rescue(vec2 u, float tolerance, float max_step, inout vec2 s, inout float residual) {
    float h = warp_damped_h();
    WarpDamped d = warp_damped_begin(s);
    bool from_u = false;
    bool running = true;
    int budget = warp_evaluations(2 * WARP_DAMPED_EVALUATIONS);
    for (int e = 0; running && e < budget; ++e) {
        vec2 f = mls_eval(warp_damped_point(d, h)).f;
        // past a CPU renderer's cap f leaves handles out: the iterates before stand
        bool whole = mls_loops_whole();
        if (whole) {
            warp_damped_take(d, f, u, h, tolerance, max_step);
        }
        if (!whole || d.phase == WARP_DAMPED_DONE || e + 1 == budget) {
            if (d.phase != WARP_DAMPED_START && !(d.least >= residual)) {
                s = d.best;
                residual = d.least;
            }
            running = !from_u && whole;
            from_u = true;
            d = warp_damped_begin(u);
        }
    }
}
