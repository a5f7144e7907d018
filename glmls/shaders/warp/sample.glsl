// Samples the source image (pixels: centres at integers, (x, y) = (column, row)).
//
//   WARP_LINEAR 0: nearest, the texel of the source pixel containing the point, so the colour
//                  is an input colour; 1: bilinear between the four nearest pixel centres.
//   WARP_BORDER    the rule outside the image (common/border.glsl).
// The texture holds the image's raw values (float32, or 8-bit normalized for uint8 images).
#include "common/blend.glsl"
#include "common/border.glsl"
#include "common/lattice.glsl"

layout(binding = BIND_SOURCE) uniform sampler2D u_source;
uniform ivec2 u_source_size;  // W, H of the source image

// Source pixel p's value, by the border rule outside the image.
vec4 warp_texel(ivec2 p) {
    return texelFetch(u_source, border_pixel(p, u_source_size), 0);
}

// The source at point s (source pixels): the backward methods. Bilinear weights are taken
// in float32 from s itself, for every border rule (constant clamps the four pixels to the
// image, "edges clamped"): the texture unit's filtering would take them from the normalized
// coordinate (s + 0.5) / size, whose rounding moves a sample at a pixel centre off it (the
// identity would not copy float images exactly), and GPUs filter with as few as 8 bits of
// sub-texel precision (weights in steps of 1/256).
vec4 warp_sample(vec2 s) {
#if WARP_LINEAR
    vec2 corner = floor(s);
    vec2 t = s - corner;
    ivec2 p = ivec2(corner);
    vec4 top = sample_blend(warp_texel(p), warp_texel(p + ivec2(1, 0)), t.x);
    vec4 bottom = sample_blend(warp_texel(p + ivec2(0, 1)), warp_texel(p + ivec2(1, 1)), t.x);
    return sample_blend(top, bottom, t.y);
#else
    return warp_texel(ivec2(floor(s + 0.5)));
#endif
}

// The source at a lattice point s (lattice pixels): nearest takes a pixel of the cell being
// drawn, lattice pixels [lo, hi], so that each cell shows its own pixels.
vec4 warp_fetch(vec2 s, ivec2 lo, ivec2 hi) {
#if WARP_LINEAR
    return warp_sample(s + vec2(u_lattice_offset));
#else
    return warp_texel(clamp(ivec2(floor(s + 0.5)), lo, hi) + u_lattice_offset);
#endif
}
