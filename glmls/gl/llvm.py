"""Two LLVMs in one process: triton's (PyTorch's compiler, which torchvision imports) and
Mesa's (the llvmpipe OpenGL driver on a machine without a GPU driver).

Mesa's driver loads its LLVM with its symbols visible to every library loaded after it;
triton's library, loaded later, then binds part of its own LLVM to Mesa's and the process
ends in a segmentation fault (an ``import torchvision`` after glmls's first warp). Loaded
first, with its symbols kept to itself, triton's library leaves Mesa's alone and both work.
So before glmls makes a GL context, :func:`load_llvm_users_first` loads triton's library
where triton is installed and nothing has loaded an LLVM yet: ~0.06 s once per process (the
library is mapped, not run; importing triton later finds it loaded). The process's resident
size grows by the pages of the library file that the loader reads (about 70 MiB with triton 3),
which the page cache shares between processes, data loaders' workers included.
"""

from __future__ import annotations

import importlib.util
import os
import sys
from pathlib import Path

__all__ = ["load_llvm_users_first", "triton_library", "triton_would_crash"]

_done: list[bool] = []


def _maps() -> str:
    try:
        return Path("/proc/self/maps").read_text(encoding="utf-8", errors="replace")
    except OSError:
        return ""


def triton_library() -> Path | None:
    """The path of triton's compiled library where triton is installed, else None (and
    where it cannot be told without importing triton)."""
    try:
        spec = importlib.util.find_spec("triton")
    except (ImportError, ValueError):
        return None
    if spec is None or not spec.submodule_search_locations:
        return None
    for folder in spec.submodule_search_locations:
        found = sorted(Path(folder, "_C").glob("libtriton*.so"))
        if found:
            return found[0]
    return None


def load_llvm_users_first() -> None:
    """Load triton's library ahead of Mesa's LLVM (see the module's docstring); once per
    process, and only where triton is installed, not yet loaded, and no LLVM is mapped yet
    (where one is, loading triton's now would be the crash itself)."""
    if _done or sys.platform != "linux":
        return
    _done.append(True)
    if "triton" in sys.modules:
        return
    library = triton_library()
    maps = _maps() if library is not None else ""
    if library is None or library.name in maps or "libLLVM" in maps:
        return
    import ctypes

    try:
        ctypes.CDLL(str(library), mode=os.RTLD_LOCAL)
    except OSError:  # a broken triton install: torchvision's own import will say so
        pass


def triton_would_crash() -> bool:
    """Whether loading triton now would end the process: it is installed, its library is not
    loaded, and another LLVM is (Mesa's, loaded before glmls could load triton's first: by a
    GL context that another library made)."""
    if "triton" in sys.modules:
        return False
    library = triton_library()
    if library is None:
        return False
    maps = _maps()
    return library.name not in maps and "libLLVM" in maps
