"""Check every shader program glmls compiles with the Khronos reference compiler.

glmls's shaders are composed at run time (``#include``, ``#define``: glmls/gl/shaders.py), so
the sources a driver sees exist only while glmls runs. With ``GLMLS_DUMP_SHADERS=FOLDER`` set,
every program glmls compiles is written to FOLDER (``glmls.gl.shaders.dump``: one file per
stage, named by its entry file and a hash of its text, with its line origins beside it). This
tool runs ``glslangValidator`` on each of them as GLSL 4.30 core for OpenGL (the stage from the
suffix), links the stages of each vertex/fragment program together, and prints every error and
warning at the shader file and line it came from, once, with the number of variants it occurs
in. It exits 1 when anything is reported that is not in ``ALLOWED`` below, 2 when
glslangValidator is missing, 0 otherwise. Mesa's llvmpipe, which runs glmls's tests, accepts
some things that stricter drivers (NVIDIA's, AMD's) reject; glslang follows the specification.

    GLMLS_DUMP_SHADERS=/tmp/shaders python -m pytest -q tests/engine tests/imaging ...
    python tools/check_shaders.py /tmp/shaders

or both at once (the tests named, or by default the GL tests):

    python tools/check_shaders.py /tmp/shaders --collect [-- PYTEST ARGUMENTS]

``--driver`` also compiles each stage with this machine's GL driver and reports its info
log (Mesa warns of a variable read before any write, for instance; on a GPU, its vendor's
compiler speaks). ``--spirv`` also compiles each stage to SPIR-V for OpenGL (``-G``,
locations and bindings mapped automatically, which GLSL does not need), which runs glslang's
code generation too.
Files under glmls/shaders/ that no dumped program includes are listed: add a test that
compiles them.
"""

from __future__ import annotations

import argparse
import fnmatch
import json
import os
import re
import shutil
import subprocess
import sys
from collections import defaultdict
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SHADERS = ROOT / "glmls" / "shaders"
SUFFIXES = (".comp", ".vert", ".frag", ".geom")
#: The GL tests, which between them compile every program glmls has.
TESTS = (
    "tests/gl tests/engine tests/imaging tests/batch tests/volume tests/analysis tests/app "
    "tests/test_inverse.py tests/test_warp_options.py"
).split()
#: (file pattern, message pattern, why it is not a fault of the shader): reports on valid
#: GLSL 4.30 core. glslang 12.0.0 makes none. (--spirv maps locations and bindings, which
#: SPIR-V for OpenGL requires of every uniform and GLSL does not, and does not run spirv-val,
#: which refuses bool uniforms, also valid GLSL.)
ALLOWED: list[tuple[str, str, str]] = [
    (
        "mls/*.glsl",
        r"^driver: `mls_batch_(first|count|out)' used uninitiali[sz]ed",
        "Mesa reads functions in source order: main writes these globals (mls_batch_begin) "
        "before it calls the functions, defined earlier, that read them",
    ),
]
_MESSAGE = re.compile(r"^(ERROR|WARNING): (?:(.*?):(\d+): )?(.*?)\s*$")
_SUMMARY = re.compile(
    r"compilation errors\.|Missing entry point|SPIR-V is not generated|'' : compilation termin"
)


def validator() -> str | None:
    return os.environ.get("GLSLANG_VALIDATOR") or shutil.which("glslangValidator")


def version(tool: str) -> str:
    out = subprocess.run([tool, "--version"], capture_output=True, text=True).stdout
    return out.splitlines()[0] if out else "unknown version"


def run(tool: str, args: list[str], cwd: Path) -> list[tuple[str, str | None, int, str]]:
    """glslang's messages: (severity, file or None, line, text)."""
    done = subprocess.run([tool, *args], capture_output=True, text=True, cwd=cwd)
    found = []
    for raw in (done.stdout + done.stderr).splitlines():
        match = _MESSAGE.match(raw)
        if match is None and raw[:1].isspace() and raw.strip() and found:  # details
            severity, file, line, text = found[-1]
            found[-1] = (severity, file, line, f"{text} {raw.strip()}")
        if match is None or _SUMMARY.search(match.group(4)):
            continue
        line = int(match.group(3)) if match.group(3) else 0
        found.append((match.group(1), match.group(2), line, match.group(4)))
    if done.returncode != 0 and not found:
        found.append(("ERROR", None, 0, f"glslangValidator exited {done.returncode}"))
    return found


_DRIVER_LINE = re.compile(r"^\s*0[:(](\d+)\)?(?:\(\d+\))?\s*:\s*(\w+)\b:?\s*(.*?)\s*$")
_STAGE_ENUMS = {".comp": 0x91B9, ".vert": 0x8B31, ".frag": 0x8B30, ".geom": 0x8DD9}


def driver_logs(folder: Path, names: list[str]) -> dict[str, list[tuple[str, None, int, str]]]:
    """Each stage compiled by this machine's GL driver (through glmls's context), its info
    log's messages: Mesa's "0:12(5): warning: ...", NVIDIA's "0(12) : warning C7050: ..."."""
    import ctypes
    import ctypes.util

    # Mesa skips compiling a source its disk cache holds, and then logs nothing
    os.environ["MESA_SHADER_CACHE_DISABLE"] = os.environ["MESA_GLSL_CACHE_DISABLE"] = "true"
    sys.path.insert(0, str(ROOT))  # this checkout's glmls
    import glmls.gl

    context = glmls.gl.get_context()
    gl = ctypes.CDLL(ctypes.util.find_library("OpenGL") or ctypes.util.find_library("GL"))
    gl.glCreateShader.restype = ctypes.c_uint
    logs = {}
    with context:
        for name in names:
            shader = gl.glCreateShader(_STAGE_ENUMS[Path(name).suffix])
            text = ctypes.c_char_p((folder / name).read_bytes())
            gl.glShaderSource(shader, 1, ctypes.byref(text), None)
            gl.glCompileShader(shader)
            size = ctypes.c_int()
            gl.glGetShaderiv(shader, 0x8B84, ctypes.byref(size))  # GL_INFO_LOG_LENGTH
            log = ctypes.create_string_buffer(max(size.value, 1))
            gl.glGetShaderInfoLog(shader, len(log), None, log)
            gl.glDeleteShader(shader)
            found = []
            for raw in log.value.decode(errors="replace").splitlines():
                match = _DRIVER_LINE.match(raw)
                if match is not None:
                    kind = "ERROR" if match.group(2).lower() == "error" else "WARNING"
                    found.append((kind, None, int(match.group(1)), match.group(3)))
                elif re.search(r"error|warning", raw, re.IGNORECASE):  # not headings
                    found.append(("WARNING", None, 0, raw.strip()))
            logs[name] = found
    return logs


def origin(about: dict, line: int) -> tuple[str, int]:
    origins = about["origins"]
    if 1 <= line <= len(origins):
        name, number = origins[line - 1]
        return name, number
    return "<composed>", line


def allowed(name: str, message: str) -> str | None:
    for pattern, text, why in ALLOWED:
        if fnmatch.fnmatch(name, pattern) and re.search(text, message):
            return why
    return None


def collect(folder: Path, pytest_args: list[str]) -> int:
    env = dict(os.environ, GLMLS_DUMP_SHADERS=str(folder))
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), env.get("PYTHONPATH")]))
    args = pytest_args or ["-q", "-p", "no:cacheprovider", *TESTS]
    return subprocess.run([sys.executable, "-m", "pytest", *args], cwd=ROOT, env=env).returncode


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("folder", type=Path, help="where GLMLS_DUMP_SHADERS wrote the sources")
    parser.add_argument("--collect", action="store_true", help="run the tests to fill it")
    parser.add_argument("--spirv", action="store_true", help="also generate SPIR-V (-G)")
    parser.add_argument(
        "--driver", action="store_true", help="also this machine's GL driver's info logs"
    )
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1)
    # pytest's own arguments for --collect follow "--" (they may start with "-")
    argv = sys.argv[1:] if argv is None else list(argv)
    split = argv.index("--") if "--" in argv else len(argv)
    options = parser.parse_args(argv[:split])
    options.pytest = argv[split + 1 :]
    tool = validator()
    if tool is None:
        print("check_shaders: glslangValidator not found (apt-get install glslang-tools)")
        return 2
    if options.collect:
        status = collect(options.folder, options.pytest)
        if status not in (0, 1):  # 1: some test failed, the sources are there all the same
            print(f"check_shaders: pytest exited {status}")
            return status
    abouts = {}
    for path in sorted(options.folder.glob("*")):
        if path.suffix in SUFFIXES and path.with_name(path.name + ".json").is_file():
            abouts[path.name] = json.loads(path.with_name(path.name + ".json").read_text())
    # sources of other shader libraries (tests compose their own): not glmls's
    ours = {
        name: about
        for name, about in abouts.items()
        if all(f == "<defines>" or (SHADERS / f).is_file() for f, _ in about["origins"])
    }
    if not ours:
        print(f"check_shaders: no glmls shader sources in {options.folder}")
        return 1
    jobs = [(name, [name]) for name in ours]
    if options.spirv:
        spirv = ["-G", "--auto-map-locations", "--auto-map-bindings", "-o", os.devnull]
        jobs += [(name, [*spirv, name]) for name in ours]
    programs = {tuple(a.get("program", ())) for a in ours.values()}
    jobs += [(p[0], ["-l", *p]) for p in sorted(programs) if len(p) > 1 and set(p) <= set(ours)]
    with ThreadPoolExecutor(max(1, options.jobs)) as pool:
        results = pool.map(lambda job: (job, run(tool, job[1], options.folder)), jobs)
        reports: dict[tuple, set[str]] = defaultdict(set)
        for (name, args), messages in results:
            files = [a for a in args if a in ours]
            for severity, file, line, text in messages:
                # glslang names a file by its path, or "0" (its first source string)
                file = file if file in ours else files[0] if len(files) == 1 else None
                where = origin(ours[file], line) if file else ("<link>", 0)
                reports[(severity, *where, text)].add(file or name)
    if options.driver:
        for name, messages in driver_logs(options.folder, sorted(ours)).items():
            for severity, _, line, text in messages:
                reports[(severity, *origin(ours[name], line), f"driver: {text}")].add(name)
    shader_files = {str(p.relative_to(SHADERS)) for p in SHADERS.rglob("*.glsl")}
    used = {f for about in ours.values() for f, _ in about["origins"]}
    print(
        f"check_shaders: {version(tool)}; {len(ours)} stages of {len(programs)} programs, "
        f"{len(abouts) - len(ours)} sources of other libraries skipped"
    )
    failures = 0
    for (severity, file, line, text), names in sorted(reports.items(), key=lambda r: r[0][1:]):
        why = allowed(file, text)
        status = f"allowed ({why})" if why else severity
        failures += why is None
        example = sorted(names)[0]
        print(f"{file}:{line}: {status}: {text}  [{len(names)} variants, e.g. {example}]")
    if shader_files - used:
        missing = ", ".join(sorted(shader_files - used))
        print(f"check_shaders: not in any dumped program (no test compiled them): {missing}")
    print(f"check_shaders: {failures} problems")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
