// f's inverse at a list of points: for each point u the source point s with f(s) = u, by
// Newton's method on f (warp/newton.glsl) from the first guess in u_guess, the rasterized
// piecewise linear inverse of the mesh over a canvas that holds every point (u_target_size
// pixels from u_origin, drawn into u_guess_size texels: one texel may span several pixels).
// The guess is the texel under u, else the covered texel of its 3 x 3 neighbourhood nearest
// to it, else u itself. Newton's steps may be as long as a few texels (u_max_step), so that
// the first step goes from a texel's centre to u.
//
// Out, per point: (s.x, s.y) scaled, |f(s) - u| in pixels, and 1 where a texel gave the
// guess, 2 where f is the identity at u and s = u (the host returns its own u there, which
// the scaled coordinates would round).
//
// WARP_RESCUE 1: the second dispatch, over the points the first left above the residual
// accepted (listed on the host, which reads the first's results anyway): inverse_out holds
// the first's results for them, improved in place by damped Newton from the first's point
// and from u (warp_rescue), as the backward method's second pass.
//
// MLS_BATCH 1 (mls/batch.glsl): many images' points in one dispatch, work group row y on
// one image (its handles, scaling and weights from the image table), its points and results
// from image * u_batch_stride on. No guess texture: each point brings its first guess (the
// host's, scaled) and its image's length unit (u_newton_unit), and u_tolerance is a share
// of that unit.
#ifndef WARP_RESCUE
#define WARP_RESCUE 0
#endif
layout(local_size_x = LOCAL_SIZE) in;

#include "mls/batch.glsl"
#if MLS_BATCH
#define WARP_UNIT_VARIES 1
#endif
#include "mls/visit.glsl"
#include "warp/frame.glsl"
#include "warp/newton.glsl"

#if MLS_BATCH  // the image table takes BIND_POINTS
struct InversePoint {
    vec4 point;   // u, the first guess: scaled
    vec4 unit;    // the image's length unit (glmls.imaging.inverse.length_unit), 0, 0, 0
};
layout(std430, binding = BIND_BATCH_POINTS) readonly buffer InversePoints {
    InversePoint inverse_points[];
};
#else
layout(std430, binding = BIND_POINTS) readonly buffer InversePoints {
    vec2 inverse_points[];   // u, scaled
};
#endif
#if WARP_RESCUE
layout(std430, binding = BIND_DEFORMED) buffer InverseOut {
#else
layout(std430, binding = BIND_DEFORMED) writeonly buffer InverseOut {
#endif
    vec4 inverse_out[];
};
#if !MLS_BATCH
layout(binding = BIND_COORDS) uniform sampler2D u_guess;   // (s.x, s.y pixels, covered, 0)
#endif

uniform ivec2 u_target_size;   // W, H of the canvas, pixels
uniform ivec2 u_guess_size;    // W, H of u_guess, texels
uniform int u_count;
uniform int u_offset;
uniform float u_tolerance;     // stop below this residual, pixels
uniform float u_max_step;      // the longest Newton step, scaled: longer with coarse texels

#if MLS_BATCH
int inverse_base;   // the work group's image's first item

// Take the work group's image: its row of the image table, its items' place and length unit.
void inverse_begin() {
    mls_batch_begin(int(gl_WorkGroupID.y));
    inverse_base = mls_batch_image_index * u_batch_stride;
    u_newton_unit = inverse_points[inverse_base].unit.x;
}

vec2 inverse_point(int j) {
    return inverse_points[inverse_base + j].point.xy;
}
#else
const int inverse_base = 0;

void inverse_begin() {
}

vec2 inverse_point(int j) {
    return inverse_points[j];
}
#endif

#if WARP_RESCUE
void main() {
    inverse_begin();
    int i = u_offset + int(gl_GlobalInvocationID.x);
    int j = min(i, max(u_count - 1, 0));
    vec2 u = inverse_point(j);
    vec4 found = inverse_out[inverse_base + j];
    vec2 s = found.xy;
    float residual = found.z / u_scale;
#if MLS_BATCH
    float tolerance = u_tolerance * u_newton_unit;
#else
    float tolerance = u_tolerance;
#endif
    warp_rescue(u, tolerance / u_scale, found.w > 0.5 ? u_max_step : 1e30, s, residual);
    if (i < u_count) {
        inverse_out[inverse_base + i] = vec4(s, residual * u_scale, found.w);
    }
}
#else
void main() {
    // No early return past the end (as mls/points.comp.glsl): those invocations redo the
    // last point, unstored.
    inverse_begin();
    int i = u_offset + int(gl_GlobalInvocationID.x);
    int j = min(i, max(u_count - 1, 0));
    vec2 u = inverse_point(j);
#if MLS_BATCH
    vec4 guess = vec4(inverse_points[inverse_base + j].point.zw, 1.0, 0.0);
    float tolerance = u_tolerance * u_newton_unit;
#else
    float tolerance = u_tolerance;
    vec2 at = (warp_output_point(u) + 0.5) * vec2(u_guess_size) / vec2(u_target_size);
    ivec2 texel = clamp(ivec2(floor(at)), ivec2(0), u_guess_size - 1);
    vec4 guess = texelFetch(u_guess, texel, 0);
    if (guess.z < 0.5) {
        float nearest = 1e30;
        for (int dy = -1; dy <= 1; ++dy) {
            for (int dx = -1; dx <= 1; ++dx) {
                ivec2 t = texel + ivec2(dx, dy);
                if (any(lessThan(t, ivec2(0))) || any(greaterThanEqual(t, u_guess_size))) {
                    continue;
                }
                vec4 g = texelFetch(u_guess, t, 0);
                vec2 d = vec2(t) + 0.5 - at;
                if (g.z > 0.5 && dot(d, d) < nearest) {
                    nearest = dot(d, d);
                    guess = g;
                }
            }
        }
    }
#endif
    bool guessed = guess.z > 0.5;
    vec2 s = guessed ? (MLS_BATCH != 0 ? guess.xy : (guess.xy - u_center) / u_scale) : u;
    float residual;
    // Without a guess (u beyond the mesh's reach: where f is close to its far-field affine
    // map) Newton's steps are not bounded: any point it ends at within the tolerance is a
    // preimage.
    float hint;   // the host measures f's stretch at the points it doubts
    s = warp_newton(s, u, tolerance / u_scale, guessed ? u_max_step : 1e30, residual, hint);
    // Where f leaves u in place (every handle in reach stays: f - v exactly 0), u is its
    // preimage exactly, where the guess's texels carry float32 noise that could move a point
    // on the canvas's edge off it; tested only where Newton ended within its tolerance of u.
    bool identity = length(s - u) * u_scale <= tolerance &&
                    all(equal(mls_eval(u).d, vec2(0.0))) && mls_loops_whole();
    s = identity ? u : s;
    residual = identity ? 0.0 : residual;
    if (i < u_count) {
        inverse_out[inverse_base + i] =
            vec4(s, residual * u_scale, identity ? 2.0 : (guessed ? 1.0 : 0.0));
    }
}
#endif
