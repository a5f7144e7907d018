// The atlas of a batch's output canvases (a buffer of RGBA8 texels, the background where the
// winner buffer says no triangle covers a pixel: the atlas is never cleared) as the caller's
// bytes: sixteen pixels an invocation, read as four uvec4 of texels and four of winners,
// their first BATCH_CHANNELS bytes packed one after the other into BATCH_CHANNELS uvec4 (the
// (N, H, W, C) uint8 array, row k * H + y of the atlas being image k's row y), and with
// BATCH_LABELS the next byte of each (a label that rode as the channel after the image's)
// into one uvec4 from u_labels_at: one read-back of the chunk into the caller's arrays, no
// channel dropped on the host. The buffers hold whole groups of sixteen pixels.
layout(local_size_x = LOCAL_SIZE) in;

#include "common/groups.glsl"

layout(std430, binding = BIND_BATCH_ATLAS) readonly buffer BatchAtlas {
    uvec4 batch_atlas[];   // the texels, one per pixel (batch/bytes.glsl), four at a time
};
layout(std430, binding = BIND_WINNER) readonly buffer WarpWinner {
    uvec4 warp_winner[];   // per pixel: 0 where no triangle covers it (batch/cells.comp.glsl)
};
layout(std430, binding = BIND_BATCH_OUTPUT) writeonly buffer BatchOutput {
    uvec4 batch_out[];
};
uniform uint u_background;  // the texel of the pixels that no triangle covers
uniform uint u_groups;      // groups of sixteen pixels
uniform int u_offset;       // first item of this dispatch
#if BATCH_LABELS
uniform uint u_labels_at;   // the labels' first uvec4
#endif

void main() {
    uint j = uint(u_offset) + dispatch_item();
    if (j >= u_groups) {
        return;
    }
    uint texels[16];
    for (uint q = 0u; q < 4u; ++q) {
        uvec4 t = batch_atlas[4u * j + q];
        uvec4 w = warp_winner[4u * j + q];
        for (uint r = 0u; r < 4u; ++r) {
            texels[4u * q + r] = w[r] != 0u ? t[r] : u_background;
        }
    }
    uint words[4 * BATCH_CHANNELS];
#if BATCH_CHANNELS == 4
    for (uint q = 0u; q < 16u; ++q) {
        words[q] = texels[q];
    }
#else
    const uint bits = 8u * uint(BATCH_CHANNELS);
    uint word = 0u;
    uint value = 0u;
    uint filled = 0u;
    for (uint q = 0u; q < 16u; ++q) {
        uint bytes = texels[q] & ((1u << bits) - 1u);
        value |= bytes << filled;
        filled += bits;
        if (filled >= 32u) {
            words[word] = value;
            ++word;
            filled -= 32u;
            value = filled > 0u ? bytes >> (bits - filled) : 0u;
        }
    }
#endif
    for (uint q = 0u; q < uint(BATCH_CHANNELS); ++q) {
        batch_out[uint(BATCH_CHANNELS) * j + q] =
            uvec4(words[4u * q], words[4u * q + 1u], words[4u * q + 2u], words[4u * q + 3u]);
    }
#if BATCH_LABELS
    uint labels[4];
    for (uint q = 0u; q < 4u; ++q) {
        labels[q] = 0u;
        for (uint r = 0u; r < 4u; ++r) {
            labels[q] |= ((texels[4u * q + r] >> (8u * uint(BATCH_CHANNELS))) & 0xFFu) << (8u * r);
        }
    }
    batch_out[u_labels_at + j] = uvec4(labels[0], labels[1], labels[2], labels[3]);
#endif
}
