#!/usr/bin/env bash
set -uo pipefail
cd "$(dirname "$0")/.." || exit 1

out=${OUT:-bench-out}
mkdir -p "$out"
if [ -z "${PYTHON:-}" ]; then
    if [ -x .venv/bin/python ]; then PYTHON=.venv/bin/python; else PYTHON=python3; fi
fi
export PYTHONPATH="$PWD${PYTHONPATH:+:$PYTHONPATH}"
failed=()
# The whole run's time: a remote GPU machine may run one command for at most 600 s, so each step
# gets at most what is left of this, and the steps past it are named as not run. The benchmarks
# run first, within their own caps; the GL tests, whose cold shader compiles take most of a fresh
# machine's time, get what is left.
budget=${GPU_CHECK_BUDGET:-480}

step() {
    local name=$1 limit=$2
    shift 2
    local left=$((budget - SECONDS))
    if ((left < 10)); then
        echo "== $name: not run (the ${budget} s budget is spent)" >&2
        failed+=("$name")
        return
    fi
    ((limit > left)) && limit=$left
    echo "== $name (at most ${limit} s)" >&2
    local start=$SECONDS
    if timeout "$limit" "$@" >"$out/$name.txt" 2>&1; then
        echo "   ok in $((SECONDS - start)) s" >&2
    else
        echo "   FAILED (status $?) in $((SECONDS - start)) s; see $out/$name.txt" >&2
        tail -n 20 "$out/$name.txt" >&2
        failed+=("$name")
    fi
}

{
    date -u +%FT%TZ
    uname -a
    nproc
    nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv 2>/dev/null || true
} >"$out/machine.txt" 2>&1
step gl-info 30 "$PYTHON" -c 'import glmls, glmls.gl as g; c = g.get_context(); i = c.mgl.info; print(glmls.__version__, i["GL_RENDERER"], i["GL_VERSION"], sep="\n")'
if [[ " ${failed[*]-} " == *" gl-info "* ]]; then
    echo "gpu_check: no GL context; nothing else can run (see $out/gl-info.txt)" >&2
    exit 1
fi
# whether the context survives a forked child's exit, by the way the child ends
step fork-probe 20 "$PYTHON" tools/fork_probe.py --timeout 8
# single warps and frames, batches, volumes: the benchmarks that matter, each in its own step
step bench 45 "$PYTHON" benchmarks/run_bench.py --quick --tools glmls --tolerances 0.05 --out "$out/bench"
step batch-bench 30 "$PYTHON" benchmarks/batch_bench.py --quick
# the host's share per image (tiny images, large batches): the 0.05 ms an image of 20,000 a second
step batch-host 25 "$PYTHON" benchmarks/batch_host.py --n 1024 --repeat 2 \
    --cases quads-g4-linear,quads-g4-nearest-kp-mask,backward,augment-grid-kp-mask
step volume-bench 35 "$PYTHON" benchmarks/volume_bench.py --size 256 --repeat 3 --memory 512 --skip-peers
step adaptive-stages-W2 10 "$PYTHON" benchmarks/adaptive_stages.py --workload W2 --tolerance 0.05
# where the time of a batch (nearest on its bytes; bilinear with the edge border, keypoints and
# masks, as Augment warps), of Augment on text crops (its draws, the edge border's margin
# search and groups) and of a volume warp goes (GPU per shader, host); a workload that fails
# does not stop the others, and the last line names it
stages() {
    local failed=()
    for workload in "batch --n 1024" "batch --n 256 --grid 4 --keypoints --interpolation linear --border edge" \
        "augment --preset text-distort --n 256 --keypoints" "volume --method backward"; do
        echo "== gl_stages.py $workload"
        # shellcheck disable=SC2086
        "$PYTHON" benchmarks/gl_stages.py $workload --top 12 || failed+=("$workload")
    done
    if ((${#failed[@]})); then
        printf 'gl_stages.py failed: %s\n' "${failed[@]}"
        return 1
    fi
}
export -f stages
export PYTHON
step gl-stages 40 bash -c stages
# pytest-xdist, where installed, runs the GL tests in parallel processes (one context each);
# -v names each failure as it happens, and SIGINT at the limit still prints the summary
parallel=()
if "$PYTHON" -c 'import xdist' 2>/dev/null; then
    parallel=(-n 14)
else
    echo "== tests: in one process (no pytest-xdist: pip install pytest-xdist)" >&2
fi
# GLMLS_DUMP_SHADERS: the tests' composed shaders, for the reference compiler below. A fresh
# GPU machine compiles every program cold, which takes most of this step.
rm -rf "$out/shaders" "$out/.pytest_cache"
gl_tests=(tests/gl tests/engine tests/imaging tests/volume tests/batch tests/test_inverse.py)
# the tests get what the benchmarks left, less the two short steps after them
tests_limit=$((budget - SECONDS - 50))
((tests_limit < 20)) && tests_limit=20
step tests "$tests_limit" env GLMLS_DUMP_SHADERS="$out/shaders" timeout -s INT $((tests_limit - 10)) "$PYTHON" -m pytest -v -rfE --durations=20 --maxfail=30 \
    -o cache_dir="$out/.pytest_cache" -p no:benchmark "${parallel[@]}" "${gl_tests[@]}"
if [[ " ${failed[*]-} " == *" tests "* ]] && ((${#parallel[@]})); then
    # the failures again, one at a time in one process: those that pass here failed only beside
    # the other workers (timing, memory, the driver under load), not by their own code path
    # (status 5: no failure recorded, the step was cut before any)
    step tests-failed-alone 30 bash -c '"$0" "$@"; rc=$?; exit $((rc == 5 ? 0 : rc))' \
        "$PYTHON" -m pytest -v -rfE --last-failed --last-failed-no-failures none \
        -o cache_dir="$out/.pytest_cache" -p no:benchmark "${gl_tests[@]}"
fi
if command -v glslangValidator >/dev/null; then
    # --driver: the vendor compiler's own warnings too
    step shaders 20 "$PYTHON" tools/check_shaders.py "$out/shaders" --driver
else
    echo "== shaders: skipped (no glslangValidator: apt-get install glslang-tools)" >&2
fi

if ((${#failed[@]})); then
    echo "gpu_check: failed: ${failed[*]} (results in $out/)" >&2
    exit 1
fi
echo "gpu_check: all steps passed (results in $out/)" >&2
