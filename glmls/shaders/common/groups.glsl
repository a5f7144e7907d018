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

// Raise an indirect dispatch's work groups x and y (``groups_x``, ``groups_y``: uints of a
// buffer, x 0 and y 0 or 1 before, z 1 throughout) to cover ``items`` items as
// dispatch_groups lays them out. Both grow with ``items``, so whatever order the writers
// come in, atomicMax leaves those of the largest: a pass sizes the next as it lists its
// items, and nothing is read back. A macro: an atomic needs the buffer variable itself, not
// a function parameter's copy.
#define DISPATCH_RAISE(groups_x, groups_y, items)         \
    {                                                     \
        uvec4 dispatch_raised_ = dispatch_groups(items);  \
        atomicMax(groups_x, dispatch_raised_.x);          \
        atomicMax(groups_y, dispatch_raised_.y);          \
    }

// This invocation's item in such a dispatch (or in a one-dimensional one).
uint dispatch_item() {
    return (gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) * uint(LOCAL_SIZE) +
           gl_LocalInvocationID.x;
}
