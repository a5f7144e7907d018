// The atlas of a batch's output canvases (a buffer of RGBA8 texels, the background where the
// winner buffer says no triangle covers a pixel: the atlas is never cleared) as the caller's
// bytes: four
// pixels an invocation, their first BATCH_CHANNELS bytes packed one after the other into
// BATCH_CHANNELS words (the (N, H, W, C) uint8 array, row k * H + y of the atlas being image
// k's row y), and with BATCH_LABELS the next byte of each (a label that rode as the channel
// after the image's) into one word from word u_labels_at: one read-back of the chunk into
// the caller's arrays, no channel dropped on the host.
layout(local_size_x = LOCAL_SIZE) in;

#include "common/groups.glsl"

layout(std430, binding = BIND_BATCH_ATLAS) readonly buffer BatchAtlas {
    uint batch_atlas[];   // the texels, one per pixel (batch/bytes.glsl)
};
layout(std430, binding = BIND_WINNER) readonly buffer WarpWinner {
    uint warp_winner[];   // per pixel: 0 where no triangle covers it (batch/cells.comp.glsl)
};
uniform uint u_background;   // the texel of the pixels that no triangle covers
layout(std430, binding = BIND_BATCH_OUTPUT) writeonly buffer BatchOutput {
    uint batch_out[];
};
uniform uint u_pixels;     // pixels of the atlas
uniform int u_offset;      // first item of this dispatch
#if BATCH_LABELS
uniform uint u_labels_at;  // the labels' first word
#endif

void main() {
    uint j = uint(u_offset) + dispatch_item();
    if (4u * j >= u_pixels) {
        return;
    }
    uint texels[4];
    for (uint q = 0u; q < 4u; ++q) {
        uint p = 4u * j + q;
        texels[q] = p < u_pixels ? (warp_winner[p] != 0u ? batch_atlas[p] : u_background) : 0u;
    }
#if BATCH_CHANNELS == 4
    for (uint q = 0u; q < 4u; ++q) {
        batch_out[4u * j + q] = texels[q];
    }
#else
    const uint bits = 8u * uint(BATCH_CHANNELS);
    uint word = uint(BATCH_CHANNELS) * j;
    uint value = 0u;
    uint filled = 0u;
    for (uint q = 0u; q < 4u; ++q) {
        uint bytes = texels[q] & ((1u << bits) - 1u);
        value |= bytes << filled;
        filled += bits;
        if (filled >= 32u) {
            batch_out[word] = value;
            ++word;
            filled -= 32u;
            value = filled > 0u ? bytes >> (bits - filled) : 0u;
        }
    }
#endif
#if BATCH_LABELS
    uint labels = 0u;
    for (uint q = 0u; q < 4u; ++q) {
        labels |= ((texels[q] >> (8u * uint(BATCH_CHANNELS))) & 0xFFu) << (8u * q);
    }
    batch_out[u_labels_at + j] = labels;
#endif
}
