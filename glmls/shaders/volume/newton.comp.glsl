// The backward method: for each output voxel u of the slab, the source point s with
// f(s) = u by Newton's method on f (source voxels), from the first guess in the coordinates
// buffer ((x, y, z, w), w >= 0: the cells' piecewise linear inverse covers u) or from u
// itself (and from u where the guess's ends above u_accept). Each step takes one evaluation
// of f and a slope, the inverse Jacobian: from a guess first its tetrahedron's (the slopes
// buffer: the piecewise linear inverse's), else, and wherever the residual falls by less
// than half in a step, f's own by forward differences (a quarter voxel: the MLS Jacobian is
// not M), kept while it converges fast; at most WARP_NEWTON_STEPS steps, each at most
// u_max_step voxels; a step that raises the residual (f curves within it, and Newton would
// cycle between two points) is halved, up to WARP_NEWTON_STEPS halvings in all; stops below
// u_tolerance or where the Jacobian is singular (a fold's edge), keeping the best point.
// Out: (s, w), w = the residual |f(s) - u| (voxels) where it is at most u_accept and
// (constant border) s is inside the volume, else -1 - residual.
//
// Two passes (glmls.gl.dispatch.SecondPass): VOLUME_NEWTON_FIRST evaluates f once per voxel,
// at its start, and stores the voxels already within u_tolerance there; it lists the others
// (BIND_RESCUE) with that evaluation, and the second pass, one invocation per listed voxel,
// resumes Newton from it. A voxel's iterates are those of one pass doing it all, but the
// voxels that need more steps than their neighbours run them together: a GPU's warp (and a
// CPU renderer's vector) runs until its slowest lane is done. The first pass's f takes only
// the solve's plain branch (mls3/solve.glsl, MLS3_SOLVE_LATER): a voxel whose start needs
// another is listed without its evaluation, and the second pass makes it.
#ifndef VOLUME_NEWTON_FIRST
#define VOLUME_NEWTON_FIRST 0
#endif
#if VOLUME_NEWTON_FIRST && !defined(MLS3_SOLVE_LATER)
#define MLS3_SOLVE_LATER 1
#endif
#if !VOLUME_NEWTON_FIRST
// one evaluation of f inlined, many made: the float64 moments sixteen handles an iteration
#define MLS3_FULL_BLOCK 16
#endif

layout(local_size_x = LOCAL_SIZE) in;

#include "volume/newton.glsl"
#include "common/stretch.glsl"

layout(std430, binding = BIND_VOLUME_SLOPES) readonly buffer VolumeSlopes {
    vec4 volume_slopes[];
};
// The voxels the first pass leaves for the second: (voxel | VOLUME_FROM_U, f at its start, or
// VOLUME_UNEVALUATED where the first pass did not evaluate it).
#define SECOND_PASS_ITEM uvec4
#include "common/second_pass.glsl"
const uint VOLUME_FROM_U = 0x80000000u;        // no guess: Newton starts at u
const uint VOLUME_UNEVALUATED = 0x7fc00000u;   // a NaN's bits, never f's

uniform int u_offset;        // first item of this dispatch
uniform int u_count;         // voxels of the slab

mat3 volume_slope(int i) {
    return mat3(volume_slopes[3 * i].xyz, volume_slopes[3 * i + 1].xyz,
                volume_slopes[3 * i + 2].xyz);
}

// The residual (voxels) up to which s counts as u's preimage where f magnifies lengths
// ``stretch`` times at s: VOLUME_ACCEPT_STEPS float32 steps of s (of its coordinates in
// voxels and in the scaled ones f takes), times the stretch, or of u, where more than
// u_accept: a thousandfold magnification makes one of s's steps a tenth of a voxel of f(s).
const float VOLUME_ACCEPT_STEPS = 4.0;
float volume_accept_at(vec3 u, vec3 s, float stretch) {
    float scaled = max(1.0, volume_far(mls3_to_scaled(s * u_volume_scale))) * u_mls3_scale /
                   min(u_volume_scale.x, min(u_volume_scale.y, u_volume_scale.z));
    float far = max(max(1.0, volume_far(u)), max(scaled, volume_far(s)) * max(stretch, 1.0));
    return max(u_accept, VOLUME_ACCEPT_STEPS * 1.1920929e-7 * far);
}

// f's stretch at s, for volume_accept_at (common/stretch.glsl): steps of VOLUME_STRETCH_H.
const int VOLUME_STRETCH_EVALUATIONS = 13;   // stretch_evaluations(3)
const float VOLUME_STRETCH_H = 0.03125;      // voxels

// Whether s, ``residual`` = |f(s) - u| (voxels), is worth f's stretch: above u_accept, but
// within volume_accept_at twice the stretch of ``jacobian`` (f's, as Newton last measured
// it by forward differences, which a jump inflates; 0 where never), the voxels that f leaves
// uncovered not among them.
bool volume_doubt(vec3 u, vec3 s, float residual, mat3 jacobian) {
    float longest = max(length(jacobian[0]), max(length(jacobian[1]), length(jacobian[2])));
    return !(residual <= u_accept) && residual <= volume_accept_at(u, s, 2.0 * longest);
}

void volume_store(int i, vec3 s, float residual, bool accepted) {
    bool found = accepted && volume_in_box(s);
    volume_coords[i] = vec4(s, found ? residual : -1.0 - min(residual, 1e30));
}

#if VOLUME_NEWTON_FIRST
void main() {
    // No early return past the end (mls/points.comp.glsl: behind a return llvmpipe reads
    // every handle lane by lane): those invocations redo the last voxel, unstored.
    int item = u_offset + int(gl_GlobalInvocationID.x);
    int i = min(item, u_count - 1);
    vec3 u = volume_target(i);
    vec4 guess = volume_coords[i];
    bool guided = guess.w >= 0.0;
    // (the slope is read by the second pass: a step taken here is not kept)
    VolumeNewton n = volume_newton_begin(guided ? guess.xyz : u, guided, mat3(1.0));
    vec3 fs = volume_f(n.s);
    bool later = mls3_solve_later;
    bool done = !later && volume_newton_take(n, fs, u);
    if (item < u_count) {
        if (done) {
            volume_store(i, n.s, n.residual, n.residual <= u_accept);
        } else {
            // every voxel has room (the list's capacity is the slab's voxels)
            second_pass_items[second_pass_slot()] =
                uvec4(uint(i) | (guided ? 0u : VOLUME_FROM_U),
                      later ? uvec3(VOLUME_UNEVALUATED) : floatBitsToUint(fs));
        }
    }
}
#else
void main() {
    // every listed voxel, however many the dispatch's work groups (at most u_max_groups);
    // an invocation's evaluations of f shared among the items it takes (mls3/newton.glsl:
    // on a CPU renderer they fit its cap on loop iterations, whatever the lanes)
    uint stride = second_pass_stride();
    int items = int((second_pass_listed() + stride - 1u) / stride);
    int most = 2 * (5 * WARP_NEWTON_STEPS + 1);
    int budget = max(mls3_evaluations(most * max(items, 1)) / max(items, 1), 1);
    // a measure of f's stretch past them where the cap leaves room for it
    int measured = most + VOLUME_STRETCH_EVALUATIONS;
    int room = mls3_evaluations(measured * max(items, 1)) / max(items, 1) >= measured
                   ? VOLUME_STRETCH_EVALUATIONS : 0;
    for (uint k = gl_GlobalInvocationID.x; k < second_pass_listed(); k += stride) {
        uvec4 entry = second_pass_items[k];
        int i = int(entry.x & ~VOLUME_FROM_U);
        vec3 u = volume_target(i);
        vec4 guess = volume_coords[i];
        bool guided = (entry.x & VOLUME_FROM_U) == 0u;
        mat3 slope = volume_slope(i);
        vec3 s = u;
        float residual = 1e30;
        // from the guess (resumed after the first pass's evaluation); where it leads off
        // (next to a fold, the cells' inverse may be another sheet's), again from u itself
        // with f's own Jacobians, keeping the better end: one flat loop of one evaluation of
        // f an iteration over both starts (one copy of f in the program, and a CPU
        // renderer's vector runs it as long as its slowest lane's own count).
        VolumeNewton n = volume_newton_begin(guided ? guess.xyz : u, guided, slope);
        bool first = true;
        bool done = false;
        if (entry.y != VOLUME_UNEVALUATED) {
            done = volume_newton_take(n, uintBitsToFloat(entry.yzw), u);
        }
        // the first start's evaluations one pass doing it all allows, less the first pass's
        int left = 5 * WARP_NEWTON_STEPS + (entry.y != VOLUME_UNEVALUATED ? 0 : 1);
        // then, where the end is in doubt (volume_doubt), f's stretch there, through the
        // same evaluation of f: probe >= 0 the next of stretch_point
        int probe = -1;
        StretchMeasure measure = stretch_begin(3);
        for (int e = 0; e < budget + room; ++e) {
            bool measuring = probe >= 0;
            vec3 fx = vec3(0.0);
            if (measuring || !done) {
                fx = volume_f(measuring ? stretch_point(s, probe, VOLUME_STRETCH_H)
                                        : volume_newton_point(n));
            }
            if (measuring) {
                stretch_take(measure, probe, fx);
                if (++probe == VOLUME_STRETCH_EVALUATIONS) {
                    break;
                }
                continue;
            }
            if (!done) {
                done = volume_newton_take(n, fx, u);
                --left;
            }
            if (done || left == 0 || e + 1 >= budget) {
                volume_newton_end(n);
                s = n.residual < residual ? n.s : s;
                residual = min(n.residual, residual);
                if (!first || residual <= u_accept || !guided) {
                    if (room > 0 && volume_doubt(u, s, residual, n.jacobian)) {
                        probe = 0;
                        continue;
                    }
                    break;
                }
                first = false;
                n = volume_newton_begin(u, false, slope);
                done = false;
                left = 5 * WARP_NEWTON_STEPS + 1;
            }
        }
        bool accepted = residual <= u_accept ||
                        (probe == VOLUME_STRETCH_EVALUATIONS &&
                         residual <= volume_accept_at(u, s, stretch_of(measure, VOLUME_STRETCH_H)));
        volume_store(i, s, residual, accepted);
    }
}
#endif
