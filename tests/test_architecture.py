"""The package's shape (docs/architecture.md): layers that import one way,
no import cycle, no module reaching into another's private names, small modules and classes."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parent.parent / "glmls"

#: Each layer may import itself and the layers before it, nothing after it.
LAYERS = (
    ("glmls.errors", "glmls.version"),
    ("glmls.core", "glmls.reference", "glmls.files", "glmls.data"),
    ("glmls.gl",),
    ("glmls.engine",),
    ("glmls.imaging", "glmls.volume"),
    ("glmls.mls", "glmls.mls3", "glmls.forking", "glmls.served"),
    ("glmls.batch",),
    ("glmls.analysis", "glmls.augment"),
    ("glmls.app",),
    ("glmls.cli",),
    ("glmls", "glmls.__main__"),  # the package root re-exports the public API
)
#: Lines of code, docstrings not counted (a numpydoc docstring with its examples is no code).
MAX_MODULE_LINES = 500
MAX_CLASS_LINES = 300


def module_name(path: Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


MODULES = {module_name(p): p for p in sorted(PACKAGE.rglob("*.py"))}


def layer(module: str) -> int:
    best = None
    for rank, prefixes in enumerate(LAYERS):
        for prefix in prefixes:
            if module == prefix or (prefix != "glmls" and module.startswith(prefix + ".")):
                if best is None or len(prefix) > best[1]:
                    best = (rank, len(prefix))
    assert best is not None, f"{module} is in no layer"
    return best[0]


def lazy_reexports(tree: ast.Module) -> set[ast.AST]:
    """The nodes of a module-level ``__getattr__`` (PEP 562): a public namespace such as
    ``glmls.gl`` re-exports a class of a higher layer on first use, which neither makes the
    lower layer depend on the higher one at import time nor creates a cycle."""
    return {
        inner
        for node in tree.body
        if isinstance(node, ast.FunctionDef) and node.name == "__getattr__"
        for inner in ast.walk(node)
    }


def imports(module: str) -> set[str]:
    """The glmls modules ``module`` imports (anywhere in it, type-checking imports too, but
    not a package's lazy re-exports)."""
    path = MODULES[module]
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    found = set()
    tree = ast.parse(path.read_text())
    lazy = lazy_reexports(tree) if path.name == "__init__.py" else set()
    for node in ast.walk(tree):
        if node in lazy:
            continue
        if isinstance(node, ast.Import):
            found |= {a.name for a in node.names if a.name.split(".")[0] == "glmls"}
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            if target.split(".")[0] != "glmls":
                continue
            for alias in node.names:
                sub = f"{target}.{alias.name}"
                found.add(sub if sub in MODULES else target)
    return found - {module}


GRAPH = {module: imports(module) for module in MODULES}


def test_every_import_points_down_the_layers():
    upward = [
        f"{module} ({layer(module)}) imports {target} ({layer(target)})"
        for module, targets in GRAPH.items()
        for target in targets
        if layer(target) > layer(module)
    ]
    assert not upward, "\n".join(upward)


def test_no_import_cycle():
    state: dict[str, int] = {}  # 1 visiting, 2 done

    def visit(module: str, stack: list[str]) -> None:
        state[module] = 1
        for target in sorted(GRAPH[module]):
            if target == "glmls" or target not in GRAPH:
                continue  # the root only re-exports
            if state.get(target) == 1:
                cycle = stack[stack.index(target) :] + [target]
                pytest.fail("import cycle: " + " -> ".join(cycle))
            if target not in state:
                visit(target, [*stack, target])
        state[module] = 2

    for module in sorted(GRAPH):
        if module not in state:
            visit(module, [module])


def _private(name: str) -> bool:
    return name.startswith("_") and not name.startswith("__")


def own_private_names(tree: ast.AST) -> set[str]:
    """Private names a module defines itself: its functions, classes and ``self._x``."""
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.ClassDef)) and _private(node.name):
            names.add(node.name)
        elif isinstance(node, ast.Attribute) and isinstance(node.ctx, ast.Store):
            owner = node.value
            if isinstance(owner, ast.Name) and owner.id == "self" and _private(node.attr):
                names.add(node.attr)
    return names


def test_no_module_uses_another_modules_private_names():
    found = []
    for module, path in MODULES.items():
        tree = ast.parse(path.read_text())
        own = own_private_names(tree)
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom):
                found += [f"{module}: imports {a.name}" for a in node.names if _private(a.name)]
            elif isinstance(node, ast.Attribute) and _private(node.attr):
                owner = node.value
                on_self = isinstance(owner, ast.Name) and owner.id in ("self", "cls")
                if not on_self and node.attr not in own:
                    found.append(f"{module}:{node.lineno}: .{node.attr}")
    assert not found, "\n".join(found)


def docstring_lines(tree: ast.AST) -> set[int]:
    """The line numbers of the module's, its classes' and its functions' docstrings."""
    lines: set[int] = set()
    kinds = (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)
    for node in ast.walk(tree):
        if isinstance(node, kinds) and node.body:
            first = node.body[0]
            if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant):
                if isinstance(first.value.value, str):
                    lines.update(range(first.lineno, first.end_lineno + 1))  # type: ignore[operator]
    return lines


def test_modules_and_classes_stay_small():
    """Lines of code, docstrings not counted: every public name documents its parameters,
    returns, errors and runnable examples (numpydoc), which must not push code apart."""
    large = []
    for module, path in MODULES.items():
        text = path.read_text()
        tree = ast.parse(text)
        docs = docstring_lines(tree)
        lines = len(text.splitlines()) - len(docs)
        if lines > MAX_MODULE_LINES:
            large.append(f"{module}: {lines} lines")
        for node in ast.walk(tree):
            if isinstance(node, ast.ClassDef):
                span = range(node.lineno, node.end_lineno + 1)  # type: ignore[arg-type]
                size = len(span) - len(docs.intersection(span))
                if size > MAX_CLASS_LINES:
                    large.append(f"{module}.{node.name}: {size} lines")
    assert not large, "\n".join(large)


def test_the_layers_are_real():
    """Every layer holds modules (the table is not stale) and the core needs no OpenGL."""
    for prefixes in LAYERS:
        assert any(layer(m) == LAYERS.index(prefixes) for m in MODULES), prefixes
    for module, path in MODULES.items():
        if module.startswith("glmls.core"):
            text = path.read_text()
            assert "moderngl" not in text and "glcontext" not in text, module


def test_uniforms_are_written_in_one_place():
    """Every uniform write goes through glmls.gl.dispatch.set_uniforms, which remembers what
    it wrote to skip repeats: a write around it would make that memory wrong."""
    found = []
    for module, path in MODULES.items():
        if module == "glmls.gl.dispatch":
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            targets = node.targets if isinstance(node, ast.Assign) else []
            targets += [node.target] if isinstance(node, (ast.AugAssign, ast.AnnAssign)) else []
            for target in targets:
                if isinstance(target, ast.Attribute) and target.attr == "value":
                    found.append(f"{module}:{node.lineno}")
            if isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute):
                if node.func.attr in ("_write_uniform", "write") and _subscript_of_program(node):
                    found.append(f"{module}:{node.lineno}")
    assert not found, "uniforms written outside set_uniforms:\n" + "\n".join(found)


def _subscript_of_program(call: ast.Call) -> bool:
    """``program["u_..."].write(...)``: a uniform member written raw."""
    owner = call.func.value  # type: ignore[attr-defined]
    return isinstance(owner, ast.Subscript) and isinstance(owner.slice, ast.Constant)


def test_importing_glmls_leaves_the_heavy_libraries_for_later():
    """``import glmls`` (and the command line's module) load no scipy and no optional
    library: every process that warps (a data loader's spawned worker, each CLI call) pays
    the import, and scipy alone takes most of a second. They load where a call needs them."""
    import subprocess
    import sys

    code = (
        "import sys, glmls, glmls.cli\n"
        "heavy = ('scipy', 'torch', 'albumentations', 'dask', 'nibabel', 'trimesh', 'glfw')\n"
        "print(sorted({m.split('.')[0] for m in sys.modules} & set(heavy)))\n"
    )
    found = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=120
    )
    assert found.stdout.strip() == "[]", found.stdout
