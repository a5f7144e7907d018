// The output slab: an image of the output's format (VOLUME_IMAGE_FORMAT, e.g. r16ui), its
// voxels stored as the source's values (integers rounded half to even and clamped).
#if VOLUME_INTEGER
layout(VOLUME_IMAGE_FORMAT, binding = BIND_VOLUME_TARGET) writeonly uniform uimage3D volume_target;
#else
layout(VOLUME_IMAGE_FORMAT, binding = BIND_VOLUME_TARGET) writeonly uniform image3D volume_target;
#endif
uniform float u_value_max;   // the integer dtype's largest value

void volume_store(ivec3 p, vec4 value) {
#if VOLUME_INTEGER
    imageStore(volume_target, p, uvec4(roundEven(clamp(value, vec4(0.0), vec4(u_value_max)))));
#else
    imageStore(volume_target, p, value);
#endif
}
