// Source pixels outside the image, by the border rule WARP_BORDER (its index in
// glmls.imaging.source.BORDERS, numpy.pad's meanings): 0 constant (the caller leaves such
// pixels to the background; a pixel index is clamped, for centres on the very edge), 1 edge,
// 2 symmetric (a b c | c b a), 3 reflect (a b c | b a), 4 wrap (a b c | a b c).
#ifndef WARP_BORDER
#define WARP_BORDER 0
#endif

// i mod n in [0, n) for any sign of i (GLSL leaves % undefined for negative operands), by
// float quotients: the first leaves a remainder within a few n of the answer (float(i)
// rounds, the division errs by a few ulps), the second within one step, set right after;
// exact for |i| below 2^30. Vector arithmetic, where an integer % is not: a CPU renderer's vector
// units have no integer division (llvmpipe divided lane by lane, and the bilinear scan of a
// reflected batch took 2.4x the constant border's time), and a GPU emulates it in many
// instructions.
int border_mod(int i, int n) {
    int m = i - int(floor(float(i) / float(n))) * n;
    m -= int(floor(float(m) / float(n))) * n;
    m += m < 0 ? n : 0;
    return m >= n ? m - n : m;
}

int border_index(int i, int n) {
#if WARP_BORDER == 2
    int m = border_mod(i, 2 * n);
    return m < n ? m : 2 * n - 1 - m;
#elif WARP_BORDER == 3
    if (n == 1) {
        return 0;
    }
    int m = border_mod(i, 2 * n - 2);
    return m < n ? m : 2 * n - 2 - m;
#elif WARP_BORDER == 4
    return border_mod(i, n);
#else
    return clamp(i, 0, n - 1);
#endif
}

// The image pixel that stands at source pixel p of an image of size (W, H).
ivec2 border_pixel(ivec2 p, ivec2 size) {
    return ivec2(border_index(p.x, size.x), border_index(p.y, size.y));
}

