// Newton's method on a 3D f, for the passes that invert it (mls3/inverse.comp.glsl,
// volume/newton.comp.glsl): how many evaluations of f an invocation may make, and the inverse
// at points as a machine that takes one evaluation of f at a time. Needs mls3/core.glsl.
//
// A CPU renderer (llvmpipe) caps an invocation's loop iterations (65,535 over all its loops,
// 4 SCAN_PIECE_PIXELS), counting them for all the lanes of a vector together, and then ends
// the loops as if done: f would leave handles out, and a point's result would depend on its
// lane mates. It also runs a loop for as long as its slowest lane: nested loops (starts >
// steps > halvings > an evaluation's walks) add up the slowest lane of each level, where one
// flat loop of one evaluation an iteration costs only the slowest lane's own count.

#include "mls3/jacobian_step.glsl"

// The loop iterations of one evaluation of f at most, where the handles are walked in loops:
// the nearest handle, a snapped point's nearest beyond the snapping distance, the moments
// (sixteen handles an iteration, mls/handles.glsl; unrolled slots walk only the second), the
// float64 solve of degenerate sets (MLS3_FULL_BLOCK handles an iteration, and its sweeps),
// the polar factor's steps, and the caller's own iteration. A CPU renderer runs a loop of a
// branch for a vector whenever one of its lanes takes it: every term counts.
int mls3_evaluation_iterations() {
    int n = u_mls3_count;
    int blocks = (n + 15) / 16;
#if MLS3_UNROLL
    int walks = blocks;
#else
    int walks = 3 * blocks;
#endif
#if MLS3_SOLVE_LATER
    int full = 0;
#else
    int full = (n + MLS3_FULL_BLOCK - 1) / MLS3_FULL_BLOCK + MLS3_FULL_SWEEPS3
             + MLS3_FULL_SWEEPS4;
#endif
    return walks + full + MLS3_POLAR_STEPS + 2;
}

// How many evaluations of f an invocation may make, at most ``most``: all of them on a GPU;
// on a CPU renderer as many as fit in its cap, 1,024 iterations left to the loops around.
int mls3_evaluations(int most) {
#if SCAN_PIECE_PIXELS == 0
    return most;
#else
    return clamp((4 * SCAN_PIECE_PIXELS - 1024) / mls3_evaluation_iterations() - 1, 1, most);
#endif
}

// Damped Newton from a start: J = df/dv by forward differences of step h
// (mls3_jacobian_step at the iterate), each step s -= (f(s) - u) J^-1 (row vectors), capped
// (mls3_newton_take), a step that raises the residual halved (up to ``steps`` halvings in
// all) and taken where none brings it down (Newton may have to climb out of a dip); at most
// ``steps`` steps, ending below ``tolerance``. The best iterate is kept. Four evaluations a
// step (three differences and the step's end, which is the next step's f), and the halvings.
const int MLS3_NEWTON_START = 0;   // next: f at the start
const int MLS3_NEWTON_DX = 1;      // next: f at s + h along x (DY, DZ: along y, z)
const int MLS3_NEWTON_DY = 2;
const int MLS3_NEWTON_DZ = 3;
const int MLS3_NEWTON_TRY = 4;     // next: f at s - move
const int MLS3_NEWTON_DONE = 5;    // within the tolerance, or out of steps

struct MLS3Newton {
    vec3 s;          // the iterate
    vec3 d;          // f(s) - s
    vec3 r;          // f(s) - u
    float residual;  // |r|
    vec3 best;       // the iterate of the least residual so far
    float least;
    float h;         // the differences' step at s
    mat3 rows;       // rows[a] = df/dv_a, being measured
    vec3 move;       // the step tried, halved while it raises the residual
    int phase;       // MLS3_NEWTON_*
    int steps;
    int halvings;
};

// The most evaluations of f one start makes: f at the start, four a step, and the halvings.
int mls3_newton_evaluations(int steps) {
    return 1 + 5 * steps;
}

MLS3Newton mls3_newton_begin(vec3 start) {
    MLS3Newton n;
    n.s = start;
    n.d = vec3(0.0);
    n.r = vec3(0.0);
    n.residual = 0.0;
    n.best = start;
    n.least = 0.0;
    n.h = 0.0;
    n.rows = mat3(0.0);
    n.move = vec3(0.0);
    n.phase = MLS3_NEWTON_START;
    n.steps = 0;
    n.halvings = 0;
    return n;
}

vec3 mls3_newton_axis(int a) {
    return vec3(equal(ivec3(a), ivec3(0, 1, 2)));
}

// Where n needs f next.
vec3 mls3_newton_point(MLS3Newton n) {
    return n.phase == MLS3_NEWTON_TRY ? n.s - n.move
         : n.phase >= MLS3_NEWTON_DX && n.phase <= MLS3_NEWTON_DZ
             ? n.s + n.h * mls3_newton_axis(n.phase - MLS3_NEWTON_DX)
             : n.s;
}

// n after it moved to s, f(s) - s = n.d: the next step's differences, or the end.
void mls3_newton_at(inout MLS3Newton n, vec3 u, float tolerance, int steps) {
    n.r = (n.s - u) + n.d;
    n.residual = length(n.r);
    n.h = mls3_jacobian_step(n.s);
    n.phase = n.steps < steps && n.residual > tolerance ? MLS3_NEWTON_DX : MLS3_NEWTON_DONE;
}

// n advanced by ``d`` = f - v at mls3_newton_point(n); never left at MLS3_NEWTON_START, so
// that best and least hold a result after the first call. A step moves s by at most
// max_step (scaled), times |s| / far where s's largest coordinate |s| is beyond far: far out
// f tends to the fit of all the handles and its curvature falls as 1 / |s|.
void mls3_newton_take(inout MLS3Newton n, vec3 d, vec3 u, float tolerance, float max_step,
                      float far, int steps) {
    if (n.phase == MLS3_NEWTON_START) {
        n.d = d;
        mls3_newton_at(n, u, tolerance, steps);
        n.best = n.s;
        n.least = n.residual;   // a NaN stays one
    } else if (n.phase == MLS3_NEWTON_TRY) {
        vec3 t = n.s - n.move;
        vec3 rt = (t - u) + d;
        if (length(rt) > n.residual && n.halvings < steps) {
            n.move *= 0.5;
            ++n.halvings;
        } else {
            n.s = t;
            n.d = d;
            ++n.steps;
            mls3_newton_at(n, u, tolerance, steps);
            n.best = n.residual < n.least ? n.s : n.best;
            n.least = min(n.residual, n.least);
        }
    } else if (n.phase != MLS3_NEWTON_DONE) {
        int a = n.phase - MLS3_NEWTON_DX;
        vec3 axis = mls3_newton_axis(a);
        // row a of J: e_a + (d(s + h e_a) - d(s)) / (the step float32 took)
        float taken = dot((n.s + n.h * axis) - n.s, axis);
        n.rows[a] = axis + (d - n.d) / taken;
        if (n.phase == MLS3_NEWTON_DZ) {
            mat3 J = transpose(n.rows);   // df = dv * J, row vectors
            float det = determinant(J);
            vec3 move = abs(det) > 1e-12 ? n.r * inverse(J) : n.r;
            vec3 a3 = abs(n.s);
            float cap = max_step * max(1.0, max(a3.x, max(a3.y, a3.z)) / far);
            float len = length(move);
            n.move = move * (len > cap ? cap / len : 1.0);
            n.phase = MLS3_NEWTON_TRY;
        } else {
            ++n.phase;
        }
    }
}
