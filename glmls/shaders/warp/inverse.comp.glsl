// The backward map: for each output pixel u, the source point s with f(s) = u.
//
//   WARP_SWAP 0: Newton's method on f (warp/newton.glsl), from the guess in u_map (the
//                rasterized piecewise linear inverse of the mesh, where it covers u) or from
//                u itself.
//             1: s = the MLS map built with the handles swapped (q -> p), the shortcut other
//                MLS tools take: the program evaluates that map's kernel. Residual unknown (-1).
//   WARP_NEWTON_STEPS  the most Newton steps.
//   WARP_RESCUE 1: the second pass (glmls.gl.dispatch.SecondPass): one invocation per pixel
//                the first listed, where Newton ended above the residual accepted: damped
//                Newton from the first's point and from u (as warp_rescue), the least
//                residual kept, then, where that gives no preimage inside the source, from
//                the points of the neighbours the first pass covered (the 5 x 5, then
//                pixels farther out in 8 directions). It runs several times over the list
//                (u_run), each run starting only from the neighbours the run before
//                found, so that a region whose first guesses all miss fills from its rim.
//                The first also lists the pixels whose preimage lies just outside the source
//                (next to a fold u has several), where Newton runs only from the neighbours
//                whose points show another sheet of f. Only those pixels pay for it. All the
//                starts of a run go in one flat loop of at most warp_evaluations evaluations
//                of f, so that a pixel's result does not depend on the pixels the list puts
//                next to it.
//
// u_map (rgba32f), per pixel: in (x, y, covered, 0) of the guess, pixels; out (s.x, s.y,
// |f(s) - u| in pixels, covered), covered = converged and s inside the source image.
#ifndef WARP_RESCUE
#define WARP_RESCUE 0
#endif

#if WARP_RESCUE
layout(local_size_x = LOCAL_SIZE) in;
#else
layout(local_size_x = LOCAL_SIZE_2D, local_size_y = LOCAL_SIZE_2D) in;
#endif

#include "mls/batch.glsl"   // MLS_BATCH: work group layer z is an image, u_map an atlas
#include "mls/visit.glsl"
#include "warp/frame.glsl"
#include "warp/newton.glsl"

layout(rgba32f, binding = BIND_INVERSE_MAP) uniform image2D u_map;

uniform ivec2 u_target_size;   // W, H of the output
uniform ivec2 u_source_size;   // W, H of the source
uniform float u_tolerance;     // stop below this residual, pixels
uniform float u_accept;        // a residual above this (pixels) leaves the pixel uncovered,
uniform float u_accept_steps;  // ... or above this many float32 steps (warp_accept)

#if !WARP_SWAP
// The pixels the first pass leaves for the second: (x | work group z << 16, y) of u_map.
#define SECOND_PASS_ITEM uvec2
#define SECOND_PASS_RUNS WARP_RESCUE
#include "common/second_pass.glsl"
#endif

// Whether s (scaled) counts as inside the source, grown by ``margin`` pixels: in its box with
// the constant border, where a point outside shows the background; with the other borders,
// which sample there, anywhere within the coordinates glmls takes (MLS_COORDINATE_LIMIT
// pixels, as the handles and points): far past them warp_accept's float32 steps grow to
// pixels, and Newton on a map that collapses the plane (every target at one point) ends
// there with residuals of many pixels.
bool warp_inside(vec2 s, float margin) {
    vec2 sp = s * u_scale + u_center;
#if WARP_BORDER == 0
    return all(greaterThanEqual(sp, vec2(-0.5 - margin))) &&
           all(lessThanEqual(sp, vec2(u_source_size) - 0.5 + margin));
#else
    return all(lessThanEqual(abs(sp), vec2(MLS_COORDINATE_LIMIT)));
#endif
}

// How far outside the source (pixels) a converged point whose Newton started at u may lie
// and be listed (a shrink lists no wide band around its image).
const float WARP_FOLD_REACH = 8.0;

// Store s (scaled), its residual (pixels) and ``covered`` (1: the first pass's; the second
// stores warp_rescued) for output pixel p at ``at`` of u_map. s goes back to pixels as the
// pixel's own point plus Newton's step s - u (u: p's point, scaled): where s stays at u (the
// identity, handles that all keep their place) the stored point is p's point exactly, as
// f(v) = v + (f(v) - v) keeps v, so that the backward methods copy a float image bit for bit;
// s * u_scale + u_center would round p's point by an ulp where u_scale is no power of two.
void warp_store(ivec2 at, ivec2 p, vec2 s, vec2 u, float residual, float covered) {
    vec2 pixel = (vec2(p) + u_origin) + (s - u) * u_scale;
    imageStore(u_map, at, vec4(pixel, residual, covered));
}

#if WARP_RESCUE
// The second pass runs again over the same list (glmls.imaging.inverse.RESCUE_RUNS), run
// u_run = 1, 2, ...: run r skips the pixels an earlier run found, and starts only from the
// neighbours that run r - 1 found (the first pass, for run 1), the others having been starts
// of the runs before. So a region that no guess led into fills from its rim inwards, run by
// run, and each pixel's result depends on the runs before alone, whichever order the
// invocations of a run take. A run follows only where the run before found a pixel.

// What run r stores as covered: above a half (covered) but not 1 (the first pass's), one
// value per run, so that the neighbours a run starts from are told apart from those that
// the run itself finds.
float warp_rescued(int run) {
    return 0.75 - float(run - 1) / 256.0;
}

// The neighbours whose points are starts: the 3 x 3 ring, then the 5 x 5.
const ivec2 WARP_NEIGHBOURS[24] = ivec2[](
    ivec2(1, 0), ivec2(-1, 0), ivec2(0, 1), ivec2(0, -1),
    ivec2(1, 1), ivec2(-1, 1), ivec2(1, -1), ivec2(-1, -1),
    ivec2(2, 0), ivec2(-2, 0), ivec2(0, 2), ivec2(0, -2),
    ivec2(2, 1), ivec2(-2, 1), ivec2(2, -1), ivec2(-2, -1),
    ivec2(1, 2), ivec2(-1, 2), ivec2(1, -2), ivec2(-1, -2),
    ivec2(2, 2), ivec2(-2, 2), ivec2(2, -2), ivec2(-2, -2));

// Then the pixels farther out, in 8 directions at WARP_FAR_LEVELS distances 3 * 2^level
// (3 to 384 pixels), nearest first: where the first guess is the mesh's cell that f
// stretches across a whole region (where the rigid fit's rotation turns fast, about a point
// where it is undefined, in the mesh's margin as over the image), it gives every
// pixel of that region a start that is no preimage, the 5 x 5 neighbours' as well; the
// covered pixels around the region lie on f's sheets that the stretched cell hides, and
// damped Newton from their points walks along those sheets to the pixel's preimage. Only for
// a pixel whose Newton did not converge: one whose point lies outside the source (the
// constant border) looks for another sheet among the near ones alone.
const int WARP_FAR_LEVELS = 8;
const ivec2 WARP_DIRECTIONS[8] = ivec2[](
    ivec2(1, 0), ivec2(-1, 0), ivec2(0, 1), ivec2(0, -1),
    ivec2(1, 1), ivec2(-1, 1), ivec2(1, -1), ivec2(-1, -1));
// How many starts the neighbours give: the 24 near ones, then the far ones.
const int WARP_STARTS = 24 + 8 * WARP_FAR_LEVELS;

// Start k's offset from the pixel (0 <= k < WARP_STARTS).
ivec2 warp_start_offset(int k) {
    return k < 24 ? WARP_NEIGHBOURS[k]
                  : WARP_DIRECTIONS[(k - 24) & 7] * (3 << ((k - 24) >> 3));
}

// A neighbour's point farther from the pixel's than this many times their spacing, plus a
// pixel, shows another sheet of f (a fold): where f does not fold, it is the inverse's
// Lipschitz bound, and a shrink by more than it costs only Newton from the neighbours.
const float WARP_SHEET = 4.0;

// The start after ``current`` (-2: the first pass's point s, -1: u, k >= 0: neighbour k's
// point; ``starts``: the neighbours left, a bit each, the 24 near ones in x, the far ones in
// y and z), into ``current`` and ``start`` (scaled); false where none is left.
bool warp_next_start(inout int current, inout uvec3 starts, vec2 s, vec2 u, ivec2 at,
                     out vec2 start) {
    if (current < -1) {   // -2 -> -1 (u)
        current = -1;
        start = u;
        return true;
    }
    // the lowest bit left: near ones first, then the far ones by distance
    int word = starts.x != 0u ? 0 : starts.y != 0u ? 1 : 2;
    uint bits = starts[word];
    current = bits != 0u ? 32 * word + findLSB(bits) - (word > 0 ? 8 : 0) : WARP_STARTS;
    starts[word] = bits & (bits - 1u);
    vec4 near = imageLoad(u_map, at + warp_start_offset(min(current, WARP_STARTS - 1)));
    start = (near.xy - u_center) / u_scale;
    return current < WARP_STARTS;
}

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= second_pass_listed()) {
        return;
    }
    uvec2 item = second_pass_items[i];
    ivec2 at = ivec2(item.x & 0xFFFFu, item.y);
#if MLS_BATCH
    mls_batch_begin(int(item.x >> 16u));
    ivec2 p = at - ivec2(0, mls_batch_image_index * u_target_size.y);
#else
    ivec2 p = at;
#endif
    vec2 u = (vec2(p) + u_origin - u_center) / u_scale;
    vec4 found = imageLoad(u_map, at);   // the first pass's point and residual, pixels
    if (found.w > 0.5) {
        return;   // found by an earlier run
    }
    vec2 s = (found.xy - u_center) / u_scale;
    float residual = found.z / u_scale;
    float tolerance = u_tolerance / u_scale;
    // Converged (then outside the source): Newton found a preimage, and only a neighbour
    // whose point shows another sheet of f is a start; else the first's point and u are (in
    // the first run), then every neighbour the run before found (the first pass, for the
    // first run): the only pixels read, and this run writes none of them.
    bool converged = residual <= warp_accept(u_accept, u_accept_steps, u, s);
    float fresh = u_run == 1 ? 1.0 : warp_rescued(u_run - 1);
    uvec3 starts = uvec3(0u);
    for (int k = 0; k < WARP_STARTS; ++k) {
        ivec2 offset = warp_start_offset(k);
        ivec2 q = p + offset;
        bool inside = all(greaterThanEqual(q, ivec2(0))) && all(lessThan(q, u_target_size));
        vec4 near = imageLoad(u_map, inside ? at + offset : at);
        float apart = length(vec2(offset));
        // where f does not fold, neighbours' preimages lie within a few of their spacing; a
        // converged pixel looks for another sheet next to it, among the near ones alone
        bool other = distance(near.xy, found.xy) > WARP_SHEET * apart + 1.0;
        bool sheet = !converged || (k < 24 && other);
        int bit = k < 24 ? k : k + 8;   // near k: bit k of x; far k: bit k - 24 of y and z
        uint mask = inside && near.w == fresh && sheet ? 1u << uint(bit & 31) : 0u;
        starts[bit >> 5] |= mask;
    }
    int current = -2;   // the start running: s first, or the first neighbour's point
    vec2 start = s;
    bool running = true;
    if (converged || u_run > 1) {
        current = -1;
        running = warp_next_start(current, starts, s, u, at, start);
        if (!running) {
            return;   // no start: the pixel stays as the run before left it
        }
    }
    bool done = false;
    float h = warp_damped_h();
    WarpDamped d = warp_damped_begin(start);
    // One flat loop, one evaluation of f an iteration, at most warp_evaluations: on a CPU
    // renderer the loop runs as long as its slowest lane, and each lane's count bounds it.
    int budget = warp_evaluations((2 + WARP_STARTS) * WARP_DAMPED_EVALUATIONS);
    for (int e = 0; running && e < budget; ++e) {
        vec2 f = mls_eval(warp_damped_point(d, h)).f;
        // past a CPU renderer's cap f leaves handles out: the iterates before stand
        bool whole = mls_loops_whole();
        if (whole) {
            warp_damped_take(d, f, u, h, tolerance, 0.2);
        }
        if (!whole || d.phase == WARP_DAMPED_DONE || e + 1 == budget) {
            bool taken = d.phase != WARP_DAMPED_START;   // f at the start was whole
            if (taken && current < 0) {   // from s or u: the least residual kept (warp_rescue)
                if (!(d.least >= residual)) {
                    s = d.best;
                    residual = d.least;
                }
                done = residual <= warp_accept(u_accept, u_accept_steps, u, s) &&
                       warp_inside(s, 0.0);
            } else if (taken && d.least <= warp_accept(u_accept, u_accept_steps, u, d.best) &&
                       warp_inside(d.best, 0.0)) {
                s = d.best;
                residual = d.least;
                done = true;
            }
            running = whole && !done && warp_next_start(current, starts, s, u, at, start);
            d = warp_damped_begin(start);
        }
    }
    if (done) {
        second_pass_done();
    }
    warp_store(at, p, s, u, residual * u_scale, done ? warp_rescued(u_run) : 0.0);
}
#else
void main() {
    // No early return past the edge (as mls/points.comp.glsl: behind a return llvmpipe
    // reads every handle lane by lane): those invocations redo the last pixel, unstored.
    ivec2 gid = ivec2(gl_GlobalInvocationID.xy);
    bool store = all(lessThan(gid, u_target_size));
    ivec2 p = min(gid, u_target_size - 1);
#if MLS_BATCH
    mls_batch_begin(int(gl_WorkGroupID.z));
    ivec2 at = p + ivec2(0, mls_batch_image_index * u_target_size.y);   // its rows of the atlas
#else
    ivec2 at = p;
#endif
    vec2 u = (vec2(p) + u_origin - u_center) / u_scale;   // the deformed point output p shows
#if WARP_SWAP
    vec2 s = mls_eval(u).f;
    float residual = -1.0;
    bool covered = warp_inside(s, 0.0);
#else
    vec4 guess = imageLoad(u_map, at);
    vec2 s = guess.z > 0.5 ? (guess.xy - u_center) / u_scale : u;
    float residual;
    float hint;
    // steps of at most a tenth of the image from the mesh's guess; from u itself (beyond the
    // mesh's reach, where f is close to its far-field fit) as long as Newton asks: a map that
    // shrinks the plane tenfold puts u's preimage ten times as far out
    float max_step = guess.z > 0.5 ? 0.2 : 1e30;
    s = warp_newton(s, u, u_tolerance / u_scale, max_step, residual, hint);
    bool converged = warp_accepted(u_accept, u_accept_steps, u, s, residual, hint);
    bool covered = converged && warp_inside(s, 0.0);
    // listed for the second pass: no preimage found, or one outside the source where
    // another may lie inside (next to a fold): by at most Newton's longest step where the
    // mesh covered u (its guess was inside), else by at most WARP_FOLD_REACH pixels (u lies
    // outside the mesh's image, so next to a fold's edge, both preimages next to the fold)
    bool near = guess.z > 0.5 || warp_inside(s, WARP_FOLD_REACH);
    if (store && !covered && (!converged || (near && warp_inside(s, 0.2 * u_scale)))) {
        int k = second_pass_slot();
        if (k >= 0) {
            second_pass_items[k] = uvec2(uint(at.x) | (gl_WorkGroupID.z << 16u), uint(at.y));
        }
    }
    residual *= u_scale;
#endif
    if (store) {
        warp_store(at, p, s, u, residual, covered ? 1.0 : 0.0);
    }
}
#endif
