// Fills each target pixel that the adaptive mesh covers from its source point, which
// adaptive/scan.comp.glsl (ADAPTIVE_FILL) wrote (ADAPTIVE_NONE where none did): the source
// sampled by warp/sample.glsl
// (nearest: the source pixel containing the point; linear: bilinear; past the image by the
// border rule). Drawn as one full-viewport triangle; the viewport has the target's size.
// Pixels no triangle covers are discarded (the background stays).
//
//   WARP_OUTPUT_COORDS 1: write (s.x, s.y, 1, 0) instead of the colour.
#ifndef ADAPTIVE_NONE
#define ADAPTIVE_NONE 3.0e38   // glmls.imaging.adaptive.scan.NONE: no source point
#endif
#include "warp/target.glsl"
#include "warp/sample.glsl"

layout(binding = BIND_COORDS) uniform sampler2D u_coords;   // s (RG32F)

layout(location = 0) out vec4 out_color;

void main() {
    ivec2 p = warp_target_pixel();
    vec2 s = texelFetch(u_coords, p, 0).xy;
    if (s.x >= ADAPTIVE_NONE) {
        discard;
    }
#if WARP_OUTPUT_COORDS
    out_color = vec4(s, 1.0, 0.0);
#else
    out_color = warp_sample(s);
#endif
}
