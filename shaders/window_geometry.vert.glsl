// Overlays in image pixel coordinates ((x, y) = (column, row), pixel centres at integers)
// drawn into the window's letterboxed image viewport: image row 0 at the top of the screen,
// like WarpPipeline.render(..., flip_y=True). Fragment shader: canvas.frag.glsl.
in vec2 in_position;
in vec4 in_color;

uniform vec2 u_size;   // image W, H

out vec4 v_color;

void main() {
    vec2 ndc = (in_position + 0.5) / u_size * 2.0 - 1.0;
    gl_Position = vec4(ndc.x, -ndc.y, 0.0, 1.0);
    v_color = in_color;
}
