// Newton's method on f: the source point s with f(s) = u (scaled coordinates), from a first
// guess. The Jacobian is taken by forward differences: the MLS Jacobian is not M (M varies
// with v). Needs mls/visit.glsl (mls_eval), u_scale (warp/frame.glsl) and WARP_NEWTON_STEPS,
// the most steps.

uniform float u_accept;        // a residual above this (pixels) is no preimage,
uniform float u_accept_steps;  // ... or above this many float32 steps (warp_accept)

// The residual (scaled) up to which s counts as a preimage of u (scaled): ``accept`` (pixels),
// or ``steps`` float32 steps of the larger coordinate of u and s where that is more: far from
// the scaling's centre float32 cannot tell f(s) from u to a twentieth of a pixel
// (glmls.imaging.inverse.accept_residual).
float warp_accept(float accept, float steps, vec2 u, vec2 s) {
    float far = max(1.0, max(max(abs(u.x), abs(u.y)), max(abs(s.x), abs(s.y))));
    return max(accept / u_scale, steps * 1.1920929e-7 * far);
}

// The best iterate from ``s``: stops once |f(s) - u| <= tolerance (scaled), after
// WARP_NEWTON_STEPS steps, or where f is singular (a fold's edge); ``residual`` is its
// |f(s) - u|, scaled. A step goes at most ``max_step`` (scaled): far from the solution,
// Newton's step may overshoot. ``damped``: a step that raises the residual (f curves within
// it, as next to a handle, and whole steps cycle) is halved, up to WARP_NEWTON_STEPS
// halvings in all, and taken where none brings it down (Newton may have to climb out of a
// dip).
vec2 warp_newton(vec2 s, vec2 u, float tolerance, float max_step, bool damped,
                 out float residual) {
    // a quarter pixel: float32 noise in f is ~1e-4 of it; damped, where f curves fast, a
    // thirty-second (noise ~1e-3 of it: the steps' directions still hold)
    float h = (damped ? 0.03125 : 0.25) / u_scale;
    vec2 r = mls_eval(s).f - u;
    residual = length(r);
    vec2 best = s;
    float least = residual;
    int halvings = damped ? 0 : WARP_NEWTON_STEPS;
    for (int k = 0; k < WARP_NEWTON_STEPS && residual > tolerance; ++k) {
        vec2 fs = r + u;
        vec2 jx = (mls_eval(s + vec2(h, 0.0)).f - fs) / h;   // df/dx
        vec2 jy = (mls_eval(s + vec2(0.0, h)).f - fs) / h;   // df/dy
        float det = jx.x * jy.y - jy.x * jx.y;
        if (!(abs(det) > 1e-12)) {
            break;   // f is singular here (a fold's edge): keep the best point so far
        }
        vec2 step = vec2(jy.y * r.x - jy.x * r.y, jx.x * r.y - jx.y * r.x) / det;
        float len = length(step);
        step *= len > max_step ? max_step / len : 1.0;
        // the step, then its halves while they raise the residual: one place evaluates f
        vec2 t;
        vec2 rt;
        bool whole = true;
        do {
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

// f's preimage of u (scaled): Newton from the first guess ``s0`` (``guessed``), else from u;
// where that ends above the residual accepted (a dip of |f(s) - u| that is no preimage,
// next to a fold or a handle), damped Newton again from s0 and from u, the least residual
// kept. The first run's point stands wherever it is a preimage, so that where f folds the
// preimage is on the guess's sheet. ``converged``: the residual is accepted.
vec2 warp_solve(vec2 s0, bool guessed, vec2 u, float tolerance, float max_step,
                out float residual, out bool converged) {
    vec2 s = warp_newton(s0, u, tolerance, max_step, false, residual);
    converged = residual <= warp_accept(u_accept, u_accept_steps, u, s);
    if (!converged) {
        float again;
        vec2 t = warp_newton(s0, u, tolerance, max_step, true, again);
        s = again < residual ? t : s;
        residual = min(again, residual);
        if (guessed) {
            t = warp_newton(u, u, tolerance, max_step, true, again);
            s = again < residual ? t : s;
            residual = min(again, residual);
        }
        converged = residual <= warp_accept(u_accept, u_accept_steps, u, s);
    }
    return s;
}
