// Flat colour per vertex (not premultiplied: blending is src_alpha, 1 - src_alpha).
in vec4 v_color;
out vec4 out_color;

void main() {
    out_color = v_color;
}
