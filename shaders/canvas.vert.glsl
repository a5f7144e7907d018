// 2-D geometry in image pixel coordinates: (x, y) = (column, row), pixel centres at integers.
// Framebuffer row y holds image row y, so reading the framebuffer back (bottom row first)
// gives the image top-down with no flip.
in vec2 in_position;
in vec4 in_color;

uniform vec2 u_size;   // W, H

out vec4 v_color;

void main() {
    gl_Position = vec4((in_position + 0.5) / u_size * 2.0 - 1.0, 0.0, 1.0);
    v_color = in_color;
}
