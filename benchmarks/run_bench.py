"""Run ``glmls bench`` from a source checkout: ``python benchmarks/run_bench.py --quick``.

Same options as ``python -m glmls.cli.bench``; see ``docs/performance.md`` for what it measures.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

if __name__ == "__main__":
    # The cases run in child processes (python -m glmls.cli.bench): they import this checkout
    # too.
    os.environ["PYTHONPATH"] = os.pathsep.join(
        filter(None, [str(ROOT), os.environ.get("PYTHONPATH")])
    )
    sys.path.insert(0, str(ROOT))
    from glmls.cli.bench import main

    sys.exit(main())
