"""The command line's start and exit (issue 28, a 10^6-state ``plan --json`` in a second): SciPy imported
without NumPy's unused submodules, NumPy left as it was; the collector frozen at exit, the output whole."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def _run(code: str) -> str:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, cwd=ROOT, check=True)
    return done.stdout


def test_scipy_imported_without_numpys_unused_submodules_and_numpy_put_back():
    out = _run(
        "import sys, json\n"
        "from beliefloc.cli.common import lean_scipy_import\n"
        "lean_scipy_import()\n"
        "import numpy\n"
        "names, listing = list(numpy.__all__), sorted(dir(numpy))\n"
        "import scipy.sparse\n"
        "loaded = sorted(m for m in ('numpy.f2py', 'numpy.testing', 'numpy.ma') if m in sys.modules)\n"
        "same = numpy.__all__ == names and sorted(dir(numpy)) == listing\n"
        "product = (scipy.sparse.csr_matrix(numpy.eye(3)) @ numpy.arange(3.0)).tolist()\n"
        "import numpy.testing, numpy.ma\n"
        "asked = 'numpy.testing' in sys.modules and hasattr(numpy, 'ma')\n"
        "hooks = sum(type(f).__name__ == '_LeanNumpyClone' for f in sys.meta_path)\n"
        "hooks = hooks if 'scipy._lib.array_api_compat.numpy' in sys.modules else 0\n"
        "print(json.dumps([loaded, same, product, asked, hooks]))\n"
    )
    loaded, same, product, asked, hooks = json.loads(out)
    assert loaded == []  # the array-API layer loaded none of them
    assert same  # NumPy's __all__ and dir() as before
    assert product == [0.0, 1.0, 2.0]
    assert asked  # still importable when asked for
    assert hooks == 0  # the finder removed itself


def test_plan_json_whole_with_the_collector_frozen_at_exit():
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    done = subprocess.run(
        [sys.executable, "-m", "beliefloc", "plan", "maps/kitchen.yaml", "--json"],
        capture_output=True, text=True, env=env, cwd=ROOT,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    result = json.loads(done.stdout)
    assert result["found"] and result["steps"]
    assert done.stderr == ""
