// The list of a second pass over the few items a first pass left (glmls.gl.dispatch.
// SecondPass, binding BIND_RESCUE): the second pass's indirect dispatch size, the count, then
// the items, SECOND_PASS_ITEM each (defined before this file: uint, uvec2, uvec4, ...).
//
//   int second_pass_slot()     the first pass: room for one more item, its index, or -1
//                              past u_rescue_capacity (counted, not listed)
//   uint second_pass_slots(n)  the first pass: room for n more, the first's index
//   uint second_pass_listed()  the second pass: how many items the list holds
//   uint second_pass_stride()  the second pass: from one of an invocation's items to its next,
//                              where the list holds more than the dispatch's invocations
//   void second_pass_done()    SECOND_PASS_RUNS 1, a second pass that runs several times
//                              (SecondPass.finish_runs, its run u_run = 1, 2, ...): an item was
//                              done in this run, so the next runs over the list (else over none)
layout(std430, binding = BIND_RESCUE) buffer SecondPassList {
    uint second_pass_groups;   // the second pass's indirect dispatch: x work groups,
    uint second_pass_y;        // y and z 1
    uint second_pass_z;
    uint second_pass_count;    // items met
    SECOND_PASS_ITEM second_pass_items[];
};
uniform uint u_rescue_capacity;   // the most items listed
uniform uint u_max_groups;        // the most work groups of the second pass's dispatch

int second_pass_slot() {
    uint k = atomicAdd(second_pass_count, 1u);
    if (k >= u_rescue_capacity) {
        return -1;
    }
    if (k % uint(LOCAL_SIZE) == 0u) {
        // one work group per LOCAL_SIZE items, at most u_max_groups: each add is followed by
        // its own min, so the last operation leaves the count within it
        atomicAdd(second_pass_groups, 1u);
        atomicMin(second_pass_groups, u_max_groups);
    }
    return int(k);
}

// The first pass: room for n more items (n >= 1), the first's index: those at or past
// u_rescue_capacity are counted, not listed (the caller leaves them out).
uint second_pass_slots(uint n) {
    uint k = atomicAdd(second_pass_count, n);
    uint capacity = u_rescue_capacity;
    uint groups = (min(k + n, capacity) + uint(LOCAL_SIZE) - 1u) / uint(LOCAL_SIZE) -
                  (min(k, capacity) + uint(LOCAL_SIZE) - 1u) / uint(LOCAL_SIZE);
    if (groups > 0u) {
        // as second_pass_slot: each add followed by its own min
        atomicAdd(second_pass_groups, groups);
        atomicMin(second_pass_groups, u_max_groups);
    }
    return k;
}

uint second_pass_listed() {
    return min(second_pass_count, u_rescue_capacity);
}

uint second_pass_stride() {
    return gl_NumWorkGroups.x * uint(LOCAL_SIZE);
}

#ifndef SECOND_PASS_RUNS
#define SECOND_PASS_RUNS 0
#endif
#if SECOND_PASS_RUNS
layout(std430, binding = BIND_RESCUE_RUNS) buffer SecondPassRuns {
    uint second_pass_runs[];   // the indirect dispatch (x, y, z) of each run after the first
};
uniform int u_run;   // this run: 1, 2, ...

void second_pass_done() {
    uint next = uint(3 * (u_run - 1));
    // an atomic only while the dispatch is not raised yet (many items may be done)
    if (second_pass_runs[next] < second_pass_groups) {
        atomicMax(second_pass_runs[next], second_pass_groups);
    }
}
#endif
