// Scan conversions that walk a primitive's pixels in one invocation (warp/cells.comp.glsl,
// batch/cells.comp.glsl, adaptive/scan.comp.glsl, warp/paper_quads.comp.glsl), on a driver
// that caps an invocation's loop iterations: Mesa's llvmpipe stops all the loops of an
// invocation after 65,535 iterations, without a word (glmls.gl.GLContext.loop_limit), so a
// primitive magnified past that many pixels would be left partly unfilled. There
// SCAN_PIECE_PIXELS (> 0, a define of every compute program, glmls.gl.context) bounds the
// pixels one invocation walks: a primitive whose pixel box holds more is walked in pieces,
// tiles of the box of at most SCAN_PIECE_PIXELS pixels (and as many rows), one per
// invocation. The dispatch over the primitives walks piece 0 of each; a primitive with more
// raises the work groups of a second, indirect dispatch (scan_pieces: x and y those of the
// first, z the most pieces of any primitive less one), in which work group z walks piece
// z + 1 of every primitive (glmls.gl.dispatch.ScanPieces). The pieces' pixels are the
// primitive's, tested and keyed as before: only who walks them changes. A mesh with no
// large primitive dispatches no work group more, and nothing is read back. Without a cap
// (SCAN_PIECE_PIXELS 0: GPU drivers) none of this is compiled.
#ifndef SCAN_PIECE_PIXELS
#define SCAN_PIECE_PIXELS 0
#endif

#if SCAN_PIECE_PIXELS
layout(std430, binding = BIND_PIECES) buffer ScanPieces {
    uint scan_pieces_x;   // the pieces' indirect dispatch (x, y, z): (0, 0, 0) before the
    uint scan_pieces_y;   // first dispatch, raised by it
    uint scan_pieces_z;
};
uniform int u_piece_first;   // 0: the dispatch over the primitives, 1: the pieces'

// This invocation's piece of the pixel box first..last, which it narrows to the piece's
// tile; false where the primitive has no such piece (an empty box has piece 0 only).
bool scan_piece(inout ivec2 first, inout ivec2 last) {
    int piece = int(gl_WorkGroupID.z) + u_piece_first;
    ivec2 size = last - first + 1;
    if (any(lessThan(size, ivec2(1)))) {
        return piece == 0;
    }
    int w = min(size.x, SCAN_PIECE_PIXELS);      // the tiles' width and height
    int h = max(SCAN_PIECE_PIXELS / w, 1);
    int across = (size.x + w - 1) / w;
    int pieces = across * ((size.y + h - 1) / h);
    if (piece == 0 && pieces > 1) {
        atomicMax(scan_pieces_x, gl_NumWorkGroups.x);
        atomicMax(scan_pieces_y, gl_NumWorkGroups.y);
        atomicMax(scan_pieces_z, uint(pieces - 1));
    }
    if (piece >= pieces) {
        return false;
    }
    int row = piece / across;
    first += ivec2((piece - row * across) * w, row * h);
    last = min(last, first + ivec2(w, h) - 1);
    return true;
}

// Is this the invocation that walks piece 0 (the one that counts or lists its primitive)?
bool scan_first_piece() {
    return gl_WorkGroupID.z == 0u && u_piece_first == 0;
}
#else
bool scan_piece(inout ivec2 first, inout ivec2 last) {
    return true;
}

bool scan_first_piece() {
    return true;
}
#endif
