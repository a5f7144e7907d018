// One-dimensional work in indirect dispatches, whose sizes a shader writes (nothing is read
// back): rows of at most DISPATCH_GROUPS_X work groups of LOCAL_SIZE invocations, and each
// invocation's item number.
#define DISPATCH_GROUPS_X 32768u

// The work groups (x, y, z, padding) for ``items`` items.
uvec4 dispatch_groups(uint items) {
    uint size = uint(LOCAL_SIZE);
    uint g = (items + size - 1u) / size;
    uint rows = (g + DISPATCH_GROUPS_X - 1u) / DISPATCH_GROUPS_X;
    return uvec4(min(g, DISPATCH_GROUPS_X), rows, 1u, 0u);
}

// This invocation's item in such a dispatch (or in a one-dimensional one).
uint dispatch_item() {
    return (gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) * uint(LOCAL_SIZE) +
           gl_LocalInvocationID.x;
}
