"""The package's shape: layers that import downward only, no import cycle, a command line that
starts without the numeric stack."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def _loaded_after(statement: str) -> set[str]:
    """The top-level modules a fresh interpreter has loaded after ``statement``."""
    code = f"import sys, json\n{statement}\nprint(json.dumps(sorted({{m.split('.')[0] for m in sys.modules}})))"
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT)
    return set(json.loads(result.stdout))


def test_building_the_command_line_loads_no_numeric_stack():
    """``beliefloc --help`` must answer at once: the CLI imports scipy and clingo only when a command
    that needs them runs."""
    heavy = {"numpy", "scipy", "clingo", "matplotlib"}
    loaded = _loaded_after("import beliefloc.cli.app")
    assert "beliefloc" in loaded  # the probe itself works
    assert not loaded & heavy, sorted(loaded & heavy)


def test_help_loads_no_numeric_stack():
    """``beliefloc --help`` itself, not only the app's import: building every command group's
    options must not reach numpy (``generate``'s choices come from a module without it)."""
    code = "import sys; sys.argv = ['beliefloc', '--help']\nfrom beliefloc.cli.app import main\ntry:\n    main()\n"
    code += "except SystemExit:\n    pass\n"
    code += "print(' '.join(sorted({m.split('.')[0] for m in sys.modules})), file=sys.stderr)"
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT)
    loaded = set(result.stderr.split())
    assert "beliefloc" in loaded and "Usage" in result.stdout  # the probe itself works
    assert not loaded & {"numpy", "scipy", "clingo", "matplotlib"}, sorted(loaded & {"numpy", "scipy"})


def test_the_command_line_runs_numpy_on_one_blas_thread_unless_told_otherwise():
    """``main`` sets one BLAS thread before any command loads numpy (threads slowed a busy
    two-core machine's localize episode by 70 %); a user's own setting stands."""
    code = (
        "import os, sys; sys.argv = ['beliefloc', '--version']\nfrom beliefloc.cli.app import main\n"
        "try:\n    main()\nexcept SystemExit:\n    pass\n"
        "import numpy\nprint(os.environ['OPENBLAS_NUM_THREADS'], os.environ['MKL_NUM_THREADS'], file=sys.stderr)"
    )
    env = {k: v for k, v in os.environ.items() if not k.endswith("_NUM_THREADS")}
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT, env=env)
    assert result.stderr.split() == ["1", "1"]
    env["OPENBLAS_NUM_THREADS"] = "2"
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT, env=env)
    assert result.stderr.split() == ["2", "1"]


def test_the_package_root_holds_only_its_face():
    """A newcomer reads the roles off the tree: the root keeps the package's face (the public API,
    the errors, the model, the belief core and the pose a belief stands for); everything else lives in
    a subpackage named for its role."""
    root_modules = {path.stem for path in (ROOT / "beliefloc").glob("*.py")}
    assert root_modules == {"__init__", "__main__", "errors", "model", "belief", "pose"}, sorted(root_modules)


def test_reading_and_validating_a_map_needs_no_scipy():
    """``validate`` loads and describes a map; only building transition matrices needs scipy."""
    statement = "from beliefloc.semantic_map import describe_map, load_map; describe_map(load_map('maps/kitchen.yaml'))"
    assert not _loaded_after(statement) & {"scipy", "PIL"}
    assert "scipy" in _loaded_after(
        statement.replace("describe_map(load_map", "__import__('beliefloc').compile_model(load_map")
    )


def test_the_package_root_is_lazy():
    """``import beliefloc`` loads nothing heavy; ``beliefloc.update`` loads the belief core when asked for."""
    assert not _loaded_after("import beliefloc") & {"numpy", "scipy", "clingo", "pydantic"}
    assert "numpy" in _loaded_after("import beliefloc; beliefloc.update")


def _graph() -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, str(ROOT / "tools" / "import_graph.py"), "--modules"], capture_output=True, text=True
    )


def test_no_import_cycle_between_modules():
    result = _graph()
    assert "cycle:" not in result.stdout, result.stdout
    assert result.returncode == 0


def test_layers_import_downward_only():
    """Nothing below the command line imports it, and only render/ and cli/ import rich."""
    edges = [line.split(" -> ") for line in _graph().stdout.splitlines() if " -> " in line]
    for source, targets in edges:
        if not source.startswith("beliefloc.cli") and source != "beliefloc.__main__":
            assert "beliefloc.cli" not in targets, source
    for path in (ROOT / "beliefloc").rglob("*.py"):
        relative = path.relative_to(ROOT / "beliefloc").parts
        if relative[0] in ("cli", "render"):
            continue
        text = path.read_text(encoding="utf-8")
        assert "import rich" not in text and "from rich" not in text, path
        assert "import typer" not in text, path


def test_the_graph_tool_finds_a_cycle(tmp_path: Path):
    """The cycle check above can fail: two modules that import each other are reported."""
    package = tmp_path / "beliefloc"
    package.mkdir()
    (package / "__init__.py").write_text("")
    (package / "a.py").write_text("from beliefloc import b\n")
    (package / "b.py").write_text("def f():\n    from beliefloc.a import x\n")
    result = subprocess.run(
        [sys.executable, str(ROOT / "tools" / "import_graph.py"), "--modules", "--root", str(tmp_path)],
        capture_output=True,
        text=True,
    )
    assert result.returncode == 1
    assert "cycle: beliefloc.a <-> beliefloc.b" in result.stdout


def test_cli_modules_share_only_common_and_options():
    """A command module takes its options from cli/options.py and its helpers from cli/common.py,
    never from another command's module (issue 12: one vocabulary, defined once); a command split in
    parts (``track.py`` and ``track_bag.py``) may import its own parts."""
    shared = {"beliefloc.cli.common", "beliefloc.cli.options"}
    for line in _graph().stdout.splitlines():
        if not line.startswith("beliefloc.cli.") or line.startswith("beliefloc.cli.app "):
            continue
        source, targets = line.split(" -> ")
        own = f"{source}_"  # a command's own parts: track_bag.py belongs to track.py
        others = {
            t.split(" ")[0] for t in targets.split(", ") if t.startswith("beliefloc.cli.") and not t.startswith(own)
        } - shared
        assert not others, f"{source} imports {sorted(others)}"
