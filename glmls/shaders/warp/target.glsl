// The target pixel that a full-viewport fill (warp/backward, warp/cells and
// warp/cells_nearest .frag.glsl) shades: the viewport has the target's size, and a window's
// framebuffer has its row 0 at the bottom (u_flip_y).
uniform ivec2 u_target_size;
uniform bool u_flip_y;

ivec2 warp_target_pixel() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    return u_flip_y ? ivec2(p.x, u_target_size.y - 1 - p.y) : p;
}
