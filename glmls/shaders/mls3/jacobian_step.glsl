// The step of J's central differences at a point (scaled units), shared by the points pass
// (where J is not the closed form's derivative, mls3/core.glsl) and the inverse: u_jacobian_step, a share of the handles' box (glmls.engine.passes3
// .jacobian_uniforms), or more where float32's rounding of f far out would outweigh it.
uniform float u_jacobian_step;
uniform float u_jacobian_floor;  // the least step per unit of max(u_jacobian_box, |v|)
uniform float u_jacobian_box;    // half the handles' box, scaled

float mls3_jacobian_step(vec3 v) {
    vec3 a = abs(v);
    return max(u_jacobian_step, u_jacobian_floor * max(u_jacobian_box, max(a.x, max(a.y, a.z))));
}
