// Colours a scalar field through a colour table (glmls.analysis.colormaps' rule):
// entry round(t (n - 1)), t = clamp((x - lo) / (hi - lo), 0, 1); undefined values in u_nan_color.
// The field is an RG32F texture of (value, defined): a separate flag rather than isnan(),
// which compilers may fold away. The viewport has the field's size.
layout(binding = BIND_VALUES) uniform sampler2D u_values;
layout(binding = BIND_COLOR_TABLE) uniform sampler2D u_table;   // n x 1, RGBA8
uniform int u_table_size;
uniform vec2 u_limits;         // lo, hi
uniform vec4 u_nan_color;
uniform float u_opacity;

out vec4 out_color;

void main() {
    vec2 sample_ = texelFetch(u_values, ivec2(gl_FragCoord.xy), 0).rg;
    vec4 color;
    if (sample_.g < 0.5) {
        color = u_nan_color;
    } else {
        float span = u_limits.y - u_limits.x;
        float t = span > 0.0 ? clamp((sample_.r - u_limits.x) / span, 0.0, 1.0) : 0.0;
        int index = int(floor(t * float(u_table_size - 1) + 0.5));
        color = texelFetch(u_table, ivec2(index, 0), 0);
    }
    out_color = vec4(color.rgb, u_opacity);
}
