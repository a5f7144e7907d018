// f's inverse at a list of points u (scaled, less u_mls3_offset as f here): Newton's method
// on f(s) = u from a start s0 (the caller's: the MLS with p and q swapped at u, u itself, a
// lattice point), as mls3/newton.glsl runs it: J by forward differences, steps capped at
// u_max_step (u_max_step |s| / u_far beyond u_far) and halved where they raise the residual,
// at most u_steps steps, ending below u_tolerance. One flat loop of one evaluation of f an
// iteration, at most mls3_evaluations: on a CPU renderer a point's result is then its own,
// whatever the points computed beside it. Writes the best s (scaled) and |f(s) - u| (scaled),
// negated where the evaluations ran out before Newton ended (glmls.engine.passes3
// .invert_points3 resumes those), 4 floats per point.
layout(local_size_x = LOCAL_SIZE) in;

// one evaluation of f inlined, many made: the float64 moments sixteen handles an iteration
#define MLS3_FULL_BLOCK 16

#include "mls3/core.glsl"
#include "mls3/jacobian_step.glsl"
#include "mls3/newton.glsl"

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

void main() {
    int i = u_offset + int(gl_GlobalInvocationID.x);
    int j = min(i, max(u_count - 1, 0));
    vec3 u = vec3(mls3_targets[6 * j], mls3_targets[6 * j + 1], mls3_targets[6 * j + 2]);
    vec3 s = vec3(mls3_targets[6 * j + 3], mls3_targets[6 * j + 4], mls3_targets[6 * j + 5]);
    MLS3Newton n = mls3_newton_begin(s);
    int budget = mls3_evaluations(mls3_newton_evaluations(u_steps));
    for (int e = 0; e < budget && n.phase != MLS3_NEWTON_DONE; ++e) {
        mls3_newton_take(n, mls3_eval(mls3_newton_point(n)).d, u, u_tolerance, u_max_step,
                         u_far, u_steps);
    }
    if (i < u_count) {
        mls3_sources[i] = vec4(n.best, n.phase == MLS3_NEWTON_DONE ? n.least : -n.least);
    }
}
