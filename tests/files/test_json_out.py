"""JSON outputs are standard JSON: a value that is not finite is null, never NaN or
Infinity, which other readers (JavaScript's JSON.parse, jq) refuse."""

from __future__ import annotations

import json
import math

import numpy as np

from glmls.files.json_out import strict_json, write_json


def test_non_finite_floats_become_null_at_any_depth(tmp_path):
    document = {
        "mean": math.nan,
        "rows": [{"spread": math.inf, "count": 3}, (1.5, -math.inf)],
        "numpy": np.float64("nan"),
        "kept": [0.0, -2.5, "inf", None, True],
    }
    want = {
        "mean": None,
        "rows": [{"spread": None, "count": 3}, [1.5, None]],
        "numpy": None,
        "kept": [0.0, -2.5, "inf", None, True],
    }
    assert strict_json(document) == want
    path = tmp_path / "out.json"
    write_json(path, document)
    text = path.read_text(encoding="utf-8")
    assert text.endswith("}\n") and "NaN" not in text and "Infinity" not in text
    assert json.loads(text, parse_constant=lambda name: (_ for _ in ()).throw(ValueError(name)))
    assert json.loads(text) == want
