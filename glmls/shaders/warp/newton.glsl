// Newton's method on f: the source point s with f(s) = u (scaled coordinates), from a first
// guess. The Jacobian is taken by forward differences: the MLS Jacobian is not M (M varies
// with v). Needs mls/visit.glsl (mls_eval), u_scale (warp/frame.glsl) and WARP_NEWTON_STEPS,
// the most steps.

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
    float h = 0.25 / u_scale;   // a quarter pixel: float32 noise in f is ~1e-4 of it
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
