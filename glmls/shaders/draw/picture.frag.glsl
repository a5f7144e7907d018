// A picture of the image's size scaled onto the viewport (common/fullscreen.vert.glsl puts
// its row 0 at the top), blended at u_opacity; pixels the picture left uncovered (alpha 0)
// stay transparent.
layout(binding = BIND_PICTURE) uniform sampler2D u_picture;
uniform float u_opacity;
in vec2 v_uv;
out vec4 out_color;

void main() {
    vec4 color = texture(u_picture, v_uv);
    out_color = vec4(color.rgb, color.a * u_opacity);
}
