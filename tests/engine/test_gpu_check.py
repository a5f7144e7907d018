"""benchmarks/gpu_check.sh runs once on a borrowed GPU machine, for a few minutes: its shell is
valid, and every option that it and the documentation's commands give a benchmark script is
one that the script takes (a renamed option would fail its step there, not here)."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
from collections import defaultdict
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
GPU_CHECK = ROOT / "benchmarks" / "gpu_check.sh"
SCRIPT = re.compile(r"((?:benchmarks|demos|tools)/\w+\.py|glmls bench)")
OPTION = re.compile(r"(?<![\w-])--[a-z][a-z-]*")
DOCS = ("docs/performance.md", "docs/volumes.md", "docs/window.md", "benchmarks/README.md")
#: Run each script with --help in one process (its imports shared) and print the texts.
HELP = """
import contextlib, io, json, os, runpy, sys
texts = {}
for path in sys.argv[1:]:
    sys.argv, text = [path, "--help"], io.StringIO()
    sys.path.insert(0, os.path.dirname(os.path.abspath(path)))  # as python PATH does
    with contextlib.redirect_stdout(text), contextlib.suppress(SystemExit):
        runpy.run_path(path, run_name="__main__")
    texts[path] = text.getvalue()
print(json.dumps(texts))
"""


def gpu_check_commands() -> list[str]:
    """gpu_check.sh's command lines that run a script, gl_stages.py once per workload."""
    text = GPU_CHECK.read_text().replace("\\\n", " ")
    commands = [line for line in text.splitlines() if SCRIPT.search(line)]
    loop = re.search(r"for workload in (.*?); do", text, re.S)
    assert loop, "gpu_check.sh's gl-stages loop"
    commands += [f"benchmarks/gl_stages.py {w}" for w in re.findall(r'"([^"]+)"', loop[1])]
    return commands


def doc_commands(text: str) -> list[str]:
    """The commands naming a script in ``text``'s fenced blocks and inline code."""
    block, prose, inside = [], [], False
    for line in text.replace("\\\n", " ").splitlines():
        if line.lstrip().startswith("```"):
            inside = not inside
        elif inside:
            block.append(line.split("#")[0])
        else:
            prose.append(line)
    spans = re.findall(r"`([^`]+)`", " ".join(prose))
    return [c for c in block + spans if SCRIPT.search(c)]


def wanted_options() -> dict[str, set[str]]:
    """Each script's path (``glmls bench``: run_bench.py) -> the options given to it."""
    commands = gpu_check_commands()
    for doc in DOCS:
        commands += doc_commands((ROOT / doc).read_text(encoding="utf-8"))
    wanted: dict[str, set[str]] = defaultdict(set)
    for command in commands:
        match = SCRIPT.search(command)
        assert match
        name = match[1].replace("glmls bench", "benchmarks/run_bench.py")
        if name != "benchmarks/NAME.py":  # benchmarks/README.md's placeholder
            wanted[name] |= set(OPTION.findall(command[match.end() :]))
    return wanted


def test_gpu_check_is_valid_shell():
    done = subprocess.run(["bash", "-n", str(GPU_CHECK)], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    if shutil.which("shellcheck"):
        done = subprocess.run(["shellcheck", str(GPU_CHECK)], capture_output=True, text=True)
        assert done.returncode == 0, done.stdout


def test_every_option_given_to_a_script_is_one_it_takes():
    wanted = wanted_options()
    assert {"benchmarks/gl_stages.py", "benchmarks/volume_bench.py"} <= set(wanted)
    missing = [name for name in wanted if not (ROOT / name).is_file()]
    assert not missing, f"scripts named that do not exist: {missing}"
    done = subprocess.run(
        [sys.executable, "-c", HELP, *sorted(wanted)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr
    helps = json.loads(done.stdout.splitlines()[-1])
    for name, options in wanted.items():
        assert helps[name].startswith("usage:"), (name, helps[name][:200])
        unknown = options - set(OPTION.findall(helps[name]))
        assert not unknown, f"{name} does not take {sorted(unknown)}"


def test_the_steps_caps_leave_the_tests_time_within_the_budget():
    """The benchmarks run first, within their own caps; the GL tests get what they leave, less
    the steps after them (the reserve): a cap raised past the budget would leave the tests
    no time on a machine whose benchmarks take their caps."""
    text = GPU_CHECK.read_text()
    budget = int(re.search(r"budget=\$\{GPU_CHECK_BUDGET:-(\d+)\}", text)[1])
    caps = {name: int(cap) for name, cap in re.findall(r"^\s*step ([\w-]+) (\d+) ", text, re.M)}
    reserve = int(re.search(r"tests_limit=\$\(\(budget - SECONDS - (\d+)\)\)", text)[1])
    after = ("tests-failed-alone", "shaders")
    assert set(after) <= set(caps) and "tests" not in caps
    assert sum(caps[name] for name in after) <= reserve
    before = sum(cap for name, cap in caps.items() if name not in after)
    assert budget - before - reserve >= 150, (budget, before, reserve)
    assert text.index("step gl-stages") < text.index("step tests ")
