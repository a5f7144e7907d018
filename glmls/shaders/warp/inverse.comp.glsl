// The backward map: for each output pixel u, the source point s with f(s) = u.
//
//   WARP_SWAP 0: Newton's method on f (warp/newton.glsl), from the guess in u_map (the
//                rasterized piecewise linear inverse of the mesh, where it covers u) or from
//                u itself.
//             1: s = the MLS map built with the handles swapped (q -> p), the shortcut other
//                MLS tools take: the program evaluates that map's kernel. Residual unknown (-1).
//   WARP_NEWTON_STEPS  the most Newton steps.
//
// u_map (rgba32f), per pixel: in (x, y, covered, 0) of the guess, pixels; out (s.x, s.y,
// |f(s) - u| in pixels, covered), covered = converged and s inside the source image.
layout(local_size_x = LOCAL_SIZE_2D, local_size_y = LOCAL_SIZE_2D) in;

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
    residual *= u_scale;
#endif
    vec2 sp = s * u_scale + u_center;
#if WARP_BORDER == 0
    bool inside = all(greaterThanEqual(sp, vec2(-0.5))) &&
                  all(lessThanEqual(sp, vec2(u_source_size) - 0.5));
#else
    bool inside = true;   // sampled by the border rule
#endif
    if (store) {
        imageStore(u_map, at, vec4(sp, residual, (converged && inside) ? 1.0 : 0.0));
    }
}
