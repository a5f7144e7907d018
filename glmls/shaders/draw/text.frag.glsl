// Glyph coverage (the atlas's red channel, 0-1) times the colour's alpha.
layout(binding = BIND_GLYPHS) uniform sampler2D u_atlas;
in vec2 v_uv;
in vec4 v_color;
out vec4 out_color;

void main() {
    float coverage = texelFetch(u_atlas, ivec2(v_uv), 0).r;
    out_color = vec4(v_color.rgb, v_color.a * coverage);
}
