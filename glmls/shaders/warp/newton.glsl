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

// The residual (scaled) up to which s counts as a preimage of u (scaled): ``accept`` (pixels),
// or ``steps`` float32 steps of the larger coordinate of u and s where that is more: far from
// the scaling's centre float32 cannot tell f(s) from u to a twentieth of a pixel
// (glmls.imaging.inverse.accept_residual).
float warp_accept(float accept, float steps, vec2 u, vec2 s) {
    float far = max(1.0, max(max(abs(u.x), abs(u.y)), max(abs(s.x), abs(s.y))));
    return max(accept / u_scale, steps * 1.1920929e-7 * far);
}

// The last iterate from ``s``: stops once |f(s) - u| <= tolerance (scaled), after
// WARP_NEWTON_STEPS steps, or where f is singular (a fold's edge); ``residual`` is its
// |f(s) - u|, scaled. A step goes at most ``max_step`` (scaled): far from the solution,
// Newton's step may overshoot.
vec2 warp_newton(vec2 s, vec2 u, float tolerance, float max_step, out float residual) {
    float h = 0.25 * u_newton_unit / u_scale;   // a quarter pixel: float32 noise in f ~1e-4 of it
    residual = 0.0;
    for (int k = 0; ; ++k) {
        vec2 r = mls_eval(s).f - u;
        residual = length(r);
        if (residual <= tolerance || k == WARP_NEWTON_STEPS) {
            break;
        }
        vec2 fs = r + u;
        vec2 jx = (mls_eval(s + vec2(h, 0.0)).f - fs) / h;   // df/dx
        vec2 jy = (mls_eval(s + vec2(0.0, h)).f - fs) / h;   // df/dy
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

// As warp_newton, for a point where it ended above the residual accepted (a dip of
// |f(s) - u| that is no preimage, next to a fold or a handle, where whole steps cycle): a
// step that raises the residual is halved, up to WARP_NEWTON_STEPS halvings in all, and
// taken where none brings it down (Newton may have to climb out of a dip); the Jacobian's
// difference is a thirty-second of a pixel (f curves fast there; float32's noise is ~1e-3
// of it, and the steps' directions still hold). Returns the best iterate. Only the second
// pass runs it (warp/inverse.comp.glsl's WARP_RESCUE, the inverse at points' second
// dispatch), over the few points the first left.
vec2 warp_newton_damped(vec2 s, vec2 u, float tolerance, float max_step, out float residual) {
    float h = 0.03125 * u_newton_unit / u_scale;
    vec2 r = mls_eval(s).f - u;
    residual = length(r);
    vec2 best = s;
    float least = residual;
    int halvings = 0;
    for (int k = 0; k < WARP_NEWTON_STEPS && residual > tolerance; ++k) {
        vec2 fs = r + u;
        vec2 jx = (mls_eval(s + vec2(h, 0.0)).f - fs) / h;   // df/dx
        vec2 jy = (mls_eval(s + vec2(0.0, h)).f - fs) / h;   // df/dy
        float det = jx.x * jy.y - jy.x * jx.y;
        if (!(abs(det) > 1e-12)) {
            break;
        }
        vec2 step = vec2(jy.y * r.x - jy.x * r.y, jx.x * r.y - jx.y * r.x) / det;
        float len = length(step);
        step *= len > max_step ? max_step / len : 1.0;
        vec2 t;
        vec2 rt;
        bool whole = true;
        do {   // the step, then its halves while they raise the residual
            if (!whole) {
                step *= 0.5;
                ++halvings;
            }
            whole = false;
            t = s - step;
            rt = mls_eval(t).f - u;
        } while (length(rt) > residual && halvings < WARP_NEWTON_STEPS);
        s = t;
        r = rt;
        residual = length(r);
        best = residual < least ? s : best;
        least = min(residual, least);
    }
    residual = least;
    return best;
}

// The preimage of u from the first pass's point ``s`` (its residual ``residual``, scaled; a
// NaN counts as none): damped Newton from s, then from u itself, the least residual kept.
void warp_rescue(vec2 u, float tolerance, float max_step, inout vec2 s, inout float residual) {
    for (int start = 0; start < 2; ++start) {   // one place runs warp_newton_damped
        float again;
        vec2 t = warp_newton_damped(start == 0 ? s : u, u, tolerance, max_step, again);
        if (!(again >= residual)) {
            s = t;
            residual = again;
        }
    }
}
