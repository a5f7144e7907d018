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
//                kept. Only those pixels pay for it.
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

// Store s (scaled) and its residual (pixels) for the pixel at ``at`` of u_map.
void warp_store(ivec2 at, vec2 s, float residual, bool converged) {
    vec2 sp = s * u_scale + u_center;
#if WARP_BORDER == 0
    bool inside = all(greaterThanEqual(sp, vec2(-0.5))) &&
                  all(lessThanEqual(sp, vec2(u_source_size) - 0.5));
#else
    bool inside = true;   // sampled by the border rule
#endif
    imageStore(u_map, at, vec4(sp, residual, (converged && inside) ? 1.0 : 0.0));
}

#if WARP_RESCUE
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
    warp_rescue(u, u_tolerance / u_scale, 0.2, s, residual);
    bool converged = residual <= warp_accept(u_accept, u_accept_steps, u, s);
    warp_store(at, s, residual * u_scale, converged);
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
    bool converged = true;
#else
    vec4 guess = imageLoad(u_map, at);
    vec2 s = guess.z > 0.5 ? (guess.xy - u_center) / u_scale : u;
    float residual;
    s = warp_newton(s, u, u_tolerance / u_scale, 0.2, residual);   // a tenth of the image
    bool converged = residual <= warp_accept(u_accept, u_accept_steps, u, s);
    if (store && !converged) {   // listed for the second pass
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
        warp_store(at, s, residual, converged);
    }
}
#endif
