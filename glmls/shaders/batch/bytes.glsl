// The sources of a batch's chunk as the caller's bytes (glmls.batch.texels): its (N, H, W, C)
// uint8 images one after the other, BATCH_CHANNELS bytes a pixel, and with BATCH_LABELS the
// (N, H, W) uint8 labels from byte u_labels_at. warp_source_texel makes the RGBA8 texel that
// the single warp's texture holds (glmls.imaging.source.as_rgba8: missing channels 0, alpha
// 255; a label as the channel after the image's), so nothing is converted on the host.
// warp_store writes a texel into the atlas of output canvases, a buffer of one texel per
// pixel, row-major, u_atlas_width pixels a row (batch/pack.comp.glsl packs it).
layout(std430, binding = BIND_BATCH_BYTES) readonly buffer BatchBytes {
    uint batch_bytes[];   // padded by a word: a read may reach one past the last byte
};
layout(std430, binding = BIND_BATCH_ATLAS) writeonly buffer BatchAtlas {
    uint batch_atlas[];
};
uniform int u_atlas_width;
// (u_source_size: W, H of one source image, declared by the including shader)
#if BATCH_LABELS
uniform uint u_labels_at;     // the labels' first byte
#endif

// The n (1..4) bytes from byte b, little-endian (the first the lowest).
uint batch_bytes_at(uint b, uint n) {
    uint word = b >> 2u;
    uint shift = (b & 3u) * 8u;
    uint value = batch_bytes[word] >> shift;
    if (shift + 8u * n > 32u) {
        value |= batch_bytes[word + 1u] << (32u - shift);
    }
    return n == 4u ? value : value & ((1u << (8u * n)) - 1u);
}

// The texel of source pixel s of the sources' atlas (image k's rows k * H ...).
uint warp_source_texel(ivec2 s) {
    uint i = uint(s.y * u_source_size.x + s.x);
    uint texel = batch_bytes_at(i * uint(BATCH_CHANNELS), uint(BATCH_CHANNELS));
#if BATCH_LABELS
    texel |= batch_bytes_at(u_labels_at + i, 1u) << (8u * uint(BATCH_CHANNELS));
#endif
#if BATCH_CHANNELS + BATCH_LABELS < 4
    texel |= 0xFF000000u;
#endif
    return texel;
}

// Texel ``texel`` at atlas pixel ``pixel``; (-1, -1): nothing to draw.
void warp_store(ivec2 pixel, uint texel) {
    if (pixel.x >= 0) {
        batch_atlas[pixel.y * u_atlas_width + pixel.x] = texel;
    }
}
