// An RGBA8 source and target bound as r32ui images (glmls.gl.bindings.bind_texels): the same
// 32-bit texels, reinterpreted, so a texel moves whole, with no conversion of each channel
// (texel fetches and fragment outputs or rgba8 image stores convert, about twice the cost on
// llvmpipe), and neither texture is copied to or from a buffer. Out of range, imageStore does
// nothing: lanes with nothing to draw store at (-1, -1). Used by the fused quads
// (warp/cells_packed.glsl) and the adaptive colour pass (ADAPTIVE_TEXELS).
// WARP_SOURCE_BYTES: the source is a batch's bytes as uploaded and the target a buffer
// (batch/bytes.glsl), the texels made and stored there.
#ifndef WARP_SOURCE_BYTES
#define WARP_SOURCE_BYTES 0
#endif

#if WARP_SOURCE_BYTES
#include "batch/bytes.glsl"
#else
layout(r32ui, binding = BIND_TEXEL_SOURCE) readonly uniform uimage2D warp_source_image;
layout(r32ui, binding = BIND_TEXEL_TARGET) writeonly uniform uimage2D warp_target_image;

uint warp_source_texel(ivec2 s) {
    return imageLoad(warp_source_image, s).x;
}

void warp_store(ivec2 pixel, uint texel) {
    imageStore(warp_target_image, pixel, uvec4(texel));
}
#endif
