// f's inverse at a list of points u (scaled, less u_mls3_offset as f here): Newton's method
// on f(s) = u from a first guess s0 (the caller's: the MLS with p and q swapped, at u), then,
// where that does not converge, from u itself. Each step s -= (f(s) - u) J^-1, J = df/dv by
// central differences (row vectors), its length capped at u_max_step (u_max_step |s| / u_far
// beyond u_far) and halved where it raises the residual; it stops below u_tolerance. Writes
// s (scaled) and |f(s) - u| (scaled), 4 floats per point.
layout(local_size_x = LOCAL_SIZE) in;

#include "mls3/core.glsl"
#include "mls3/jacobian_step.glsl"

layout(std430, binding = BIND_POINTS) readonly buffer MLS3Targets {
    float mls3_targets[];   // u, then s0, 6 floats per point
};
layout(std430, binding = BIND_DEFORMED) writeonly buffer MLS3Sources {
    vec4 mls3_sources[];    // s, |f(s) - u|
};
uniform int u_count;
uniform int u_offset;
uniform float u_tolerance;
uniform float u_max_step;
uniform int u_steps;
uniform float u_far;        // scaled |s| past which the cap grows with it

vec3 mls3_residual(vec3 s, vec3 u) {
    return (s - u) + mls3_eval(s).d;
}

// Newton from s; returns the least |f(s) - u| it reached and leaves s there. A step that
// raises the residual (f curves within it, and Newton would cycle or leave) is halved, up to
// u_steps halvings in all, and taken where none brings it down (Newton may have to climb
// out of a dip).
float mls3_newton(inout vec3 s, vec3 u) {
    vec3 r = mls3_residual(s, u);
    float residual = length(r);
    vec3 best = s;
    float least = residual;
    int halvings = 0;
    for (int k = 0; k < u_steps && residual > u_tolerance; ++k) {
        mat3 J = mls3_jacobian(s, mls3_jacobian_step(s));
        float det = determinant(J);
        vec3 move = abs(det) > 1e-12 ? r * inverse(J) : r;
        // far out f tends to the fit of all the handles and its curvature falls as 1 / |s|:
        // the cap grows with |s| past u_far (glmls.engine.passes3.NEWTON_FAR3)
        vec3 a = abs(s);
        float cap = u_max_step * max(1.0, max(a.x, max(a.y, a.z)) / u_far);
        float len = length(move);
        move *= len > cap ? cap / len : 1.0;
        // the step, then its halves while they raise the residual: one place evaluates f
        vec3 t;
        vec3 rt;
        bool whole = true;
        do {
            if (!whole) {
                move *= 0.5;
                ++halvings;
            }
            whole = false;
            t = s - move;
            rt = mls3_residual(t, u);
        } while (length(rt) > residual && halvings < u_steps);
        s = t;
        r = rt;
        residual = length(r);
        best = residual < least ? s : best;
        least = min(residual, least);
    }
    s = best;
    return least;
}

void main() {
    int i = u_offset + int(gl_GlobalInvocationID.x);
    int j = min(i, max(u_count - 1, 0));
    vec3 u = vec3(mls3_targets[6 * j], mls3_targets[6 * j + 1], mls3_targets[6 * j + 2]);
    vec3 s = vec3(mls3_targets[6 * j + 3], mls3_targets[6 * j + 4], mls3_targets[6 * j + 5]);
    float residual = mls3_newton(s, u);
    if (residual > u_tolerance) {
        vec3 t = u;
        float again = mls3_newton(t, u);
        s = again < residual ? t : s;
        residual = min(again, residual);
    }
    if (i < u_count) {
        mls3_sources[i] = vec4(s, residual);
    }
}
