// Samples the source image at a source point s (pixels, centres at integers).
//
//   WARP_LINEAR 0: nearest, the texel of the source pixel containing s, clamped to the pixels
//                  [lo, hi] (the cell being drawn), so the colour is an input colour;
//               1: bilinear between the four nearest pixel centres, edges clamped.
// The texture holds the image's raw values (float32, or 8-bit normalized for uint8 images).
layout(binding = BIND_SOURCE) uniform sampler2D u_source;
uniform ivec2 u_source_size;  // W, H of the source image

vec4 warp_fetch(vec2 s, ivec2 lo, ivec2 hi) {
#if WARP_LINEAR
    return texture(u_source, (s + 0.5) / vec2(textureSize(u_source, 0)));
#else
    return texelFetch(u_source, clamp(ivec2(floor(s + 0.5)), lo, hi), 0);
#endif
}
