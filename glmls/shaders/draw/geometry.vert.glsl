// 2-D geometry in image pixel coordinates: (x, y) = (column, row), pixel centres at integers,
// u_size = (W, H) pixels from u_origin (the point at pixel (0, 0); 0 unless a window shows
// another canvas than the image's) mapped onto the viewport. Without u_flip_y, framebuffer row y
// holds image row y, so reading the framebuffer back (bottom row first) gives the image
// top-down with no flip (offscreen pictures); with it, image row 0 is at the top of the
// viewport (a window). Fragment shader: draw/color.frag.glsl.
in vec2 in_position;
in vec4 in_color;

uniform vec2 u_size;
uniform vec2 u_origin;
uniform bool u_flip_y;

out vec4 v_color;

void main() {
    vec2 ndc = (in_position - u_origin + 0.5) / u_size * 2.0 - 1.0;
    gl_Position = vec4(ndc.x, u_flip_y ? -ndc.y : ndc.y, 0.0, 1.0);
    v_color = in_color;
}
