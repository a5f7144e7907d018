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
//                Newton from the first's point and from u (warp_rescue), the least residual
//                kept, then, where that gives no preimage inside the source, from the points
//                of the neighbours the first pass covered. The first also lists the pixels
//                whose preimage lies outside the source by at most Newton's longest step
//                (next to a fold u has several). Only those pixels pay for it.
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
// The pixels the first pass leaves above the residual accepted, for the second.
layout(std430, binding = BIND_RESCUE) buffer WarpRescue {
    uint warp_rescue_groups;     // the second pass's indirect dispatch: x work groups,
    uint warp_rescue_y;          // y and z 1
    uint warp_rescue_z;
    uint warp_rescue_count;      // pixels met (those past u_rescue_capacity are not listed)
    uvec2 warp_rescue_items[];   // (x | work group z << 16, y) of u_map
};
uniform uint u_rescue_capacity;
#endif

// Whether s (scaled) counts as inside the source, grown by ``margin`` pixels: in its box with
// the constant border, where a point outside shows the background; anywhere with the other
// borders, which sample there.
bool warp_inside(vec2 s, float margin) {
    vec2 sp = s * u_scale + u_center;
#if WARP_BORDER == 0
    return all(greaterThanEqual(sp, vec2(-0.5 - margin))) &&
           all(lessThanEqual(sp, vec2(u_source_size) - 0.5 + margin));
#else
    return true;
#endif
}

// Store s (scaled), its residual (pixels) and ``covered`` (1: the first pass's; the second
// stores WARP_RESCUED) for the pixel at ``at`` of u_map.
void warp_store(ivec2 at, vec2 s, float residual, float covered) {
    imageStore(u_map, at, vec4(s * u_scale + u_center, residual, covered));
}

#if WARP_RESCUE
// What the second pass stores as covered: above a half (covered) but not 1, so that the
// neighbours it starts from are those the first pass covered, whichever order it runs in.
const float WARP_RESCUED = 0.75;

// The neighbours whose points are starts: the 3 x 3 ring, then the 5 x 5.
const ivec2 WARP_NEIGHBOURS[24] = ivec2[](
    ivec2(1, 0), ivec2(-1, 0), ivec2(0, 1), ivec2(0, -1),
    ivec2(1, 1), ivec2(-1, 1), ivec2(1, -1), ivec2(-1, -1),
    ivec2(2, 0), ivec2(-2, 0), ivec2(0, 2), ivec2(0, -2),
    ivec2(2, 1), ivec2(-2, 1), ivec2(2, -1), ivec2(-2, -1),
    ivec2(1, 2), ivec2(-1, 2), ivec2(1, -2), ivec2(-1, -2),
    ivec2(2, 2), ivec2(-2, 2), ivec2(2, -2), ivec2(-2, -2));

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= min(warp_rescue_count, u_rescue_capacity)) {
        return;
    }
    uvec2 item = warp_rescue_items[i];
    ivec2 at = ivec2(item.x & 0xFFFFu, item.y);
#if MLS_BATCH
    mls_batch_begin(int(item.x >> 16u));
    ivec2 p = at - ivec2(0, mls_batch_image_index * u_target_size.y);
#else
    ivec2 p = at;
#endif
    vec2 u = (vec2(p) + u_origin - u_center) / u_scale;
    vec4 found = imageLoad(u_map, at);   // the first pass's point and residual, pixels
    vec2 s = (found.xy - u_center) / u_scale;
    float residual = found.z / u_scale;
    float tolerance = u_tolerance / u_scale;
    if (!(residual <= warp_accept(u_accept, u_accept_steps, u, s))) {
        warp_rescue(u, tolerance, 0.2, s, residual);
    }
    bool done = residual <= warp_accept(u_accept, u_accept_steps, u, s) && warp_inside(s, 0.0);
    // Else (next to a fold f has several preimages of u, and Newton may end at one outside
    // the source, or at none) damped Newton from the points of the neighbours the first pass
    // covered, the nearest first, until one ends at a preimage inside the source.
    for (int k = 0; k < 24 && !done; ++k) {
        ivec2 q = p + WARP_NEIGHBOURS[k];
        if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, u_target_size))) {
            continue;
        }
        vec4 near = imageLoad(u_map, at + WARP_NEIGHBOURS[k]);
        if (near.w != 1.0) {
            continue;
        }
        float again;
        vec2 t = warp_newton_damped((near.xy - u_center) / u_scale, u, tolerance, 0.2, again);
        if (again <= warp_accept(u_accept, u_accept_steps, u, t) && warp_inside(t, 0.0)) {
            s = t;
            residual = again;
            done = true;
        }
    }
    warp_store(at, s, residual * u_scale, done ? WARP_RESCUED : 0.0);
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
    s = warp_newton(s, u, u_tolerance / u_scale, 0.2, residual);   // a tenth of the image
    bool converged = residual <= warp_accept(u_accept, u_accept_steps, u, s);
    bool covered = converged && warp_inside(s, 0.0);
    // listed for the second pass: no preimage found, or one outside the source by at most
    // Newton's longest step, where another may lie inside (next to a fold)
    if (store && !covered && (!converged || warp_inside(s, 0.2 * u_scale))) {
        uint i = atomicAdd(warp_rescue_count, 1u);
        if (i < u_rescue_capacity) {
            warp_rescue_items[i] = uvec2(uint(at.x) | (gl_WorkGroupID.z << 16u), uint(at.y));
            if (i % uint(LOCAL_SIZE) == 0u) {
                atomicAdd(warp_rescue_groups, 1u);
            }
        }
    }
    residual *= u_scale;
#endif
    if (store) {
        warp_store(at, s, residual, covered ? 1.0 : 0.0);
    }
}
#endif
