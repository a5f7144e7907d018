// Whether a CPU renderer's cap on an invocation's loop iterations has left every loop of this
// invocation whole so far (glmls.engine.loops): Mesa's llvmpipe counts the iterations of all
// the loops of an invocation, for a vector of lanes together, and past 65,535 ends each loop
// after its first iteration as if it were done, without a word. A loop of ``two`` iterations
// runs both only while the cap has room. ``two`` must be 2 from a value the compiler cannot
// know (a loop of a constant count is unrolled, and never capped). Without a cap (LOOP_CAP
// 0, a define of every compute program, glmls.gl.context: GPU drivers) always true, and no
// code.
#ifndef LOOP_CAP
#define LOOP_CAP 0
#endif

bool loops_whole(int two) {
#if LOOP_CAP
    int runs = 0;
    for (int k = 0; k < two; ++k) {
        ++runs;
    }
    return runs == 2;
#else
    return true;
#endif
}
