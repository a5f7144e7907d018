// Text and panels in window framebuffer pixels, origin at the top left (y down).
in vec2 in_position;
in vec2 in_uv;         // texel of the glyph atlas
in vec4 in_color;

uniform vec2 u_screen; // framebuffer W, H

out vec2 v_uv;
out vec4 v_color;

void main() {
    vec2 ndc = in_position / u_screen * 2.0 - 1.0;
    gl_Position = vec4(ndc.x, -ndc.y, 0.0, 1.0);
    v_uv = in_uv;
    v_color = in_color;
}
