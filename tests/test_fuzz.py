"""Hostile input: the fuzz corpus and random files fed to every loader.

The only outcomes allowed are a valid result or a :class:`BeliefLocError` (exit 2 on the command
line): never another exception, a native crash, a hang or a blow-up of memory.
"""

from __future__ import annotations

import json
import os
import resource
import subprocess
import sys
import textwrap
from collections.abc import Iterator
from datetime import timedelta
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from beliefloc.errors import BeliefLocError

from .conftest import MAPS, ROOT

FUZZ = ROOT / "tests" / "data" / "fuzz"
DOMAINS = ROOT / "domains"
MEMORY_BOUND = 3 * 1024**3
"""Address space of the process that reads the corpus: the bound on memory the issue asks for."""
TIME_BOUND = 600
"""Seconds for the whole corpus (a hang, not a speed measurement: it takes well under a minute)."""


def _corpus() -> list[list[str]]:
    """The command line that reads each corpus file, by the kind of file its folder holds."""
    runs: list[list[str]] = []
    for path in sorted(FUZZ.rglob("*")):
        if not path.is_file() or path.name == "README.md" or "includes" in path.parts:
            continue
        kind = path.relative_to(FUZZ).parts[0]
        if kind in ("yaml", "maps"):
            runs.append(["validate", str(path)])
        elif kind == "domains":
            runs.append(["kb", "check", str(path)])
        elif kind == "kb":
            runs.append(["kb", "check", str(DOMAINS / "home.yaml"), "--kb", str(path)])
        elif kind in ("npz", "pomdp"):
            runs.append(["inspect", str(path)])
        elif kind == "results":
            runs.append(["summarize", str(path)])
        elif kind == "beliefs":
            runs.append(["pose", str(MAPS / "apartment.yaml"), "--belief", str(path)])
    return runs


_DRIVER = textwrap.dedent(
    """
    import json, resource, sys
    from typer.testing import CliRunner
    from beliefloc.cli.app import app

    resource.setrlimit(resource.RLIMIT_AS, ({bound}, {bound}))
    runner = CliRunner()
    outcomes = []
    for args in json.loads(sys.stdin.read()):
        result = runner.invoke(app, args)
        crash = None if result.exception is None or isinstance(result.exception, SystemExit) else repr(result.exception)
        outcomes.append({{"args": args, "exit": result.exit_code, "crash": crash, "out": result.output[-300:]}})
    print(json.dumps(outcomes))
    """
)


@pytest.mark.slow
def test_every_corpus_file_is_read_or_refused_within_bounds(tmp_path: Path):
    """One process reads the whole corpus under a memory bound: a segfault, a hang or a blow-up
    would kill it; every file must end in exit 0 or 2 and never in an unexpected exception."""
    runs = _corpus()
    assert len(runs) >= 50, "the corpus is missing"
    env = {**os.environ, "COLUMNS": "200", "BELIEFLOC_MAX_KB_SECONDS": "10"}
    result = subprocess.run(
        [sys.executable, "-c", _DRIVER.format(bound=MEMORY_BOUND)],
        input=json.dumps(runs),
        capture_output=True,
        text=True,
        timeout=TIME_BOUND,
        cwd=tmp_path,
        env=env,
    )
    assert result.returncode == 0, f"the reading process died ({result.returncode}): {result.stderr[-2000:]}"
    outcomes = json.loads(result.stdout)
    bad = [o for o in outcomes if o["crash"] is not None or o["exit"] not in (0, 2) or "Traceback" in o["out"]]
    assert not bad, json.dumps(bad, indent=1)
    refused = sum(o["exit"] == 2 for o in outcomes)
    assert refused >= len(outcomes) // 2  # the corpus is mostly causes of errors


# --- random files ------------------------------------------------------------------------------------

_KEYS = st.sampled_from(
    [
        "name",
        "grid",
        "rows",
        "cols",
        "cell_size",
        "headings",
        "layout",
        "landmarks",
        "class",
        "cell",
        "x",
        "y",
        "actions",
        "forward",
        "cost",
        "failure",
        "sensors",
        "type",
        "look",
        "scan",
        "here",
        "classes",
        "bins",
        "beams",
        "range",
        "fov",
        "passive",
        "annotations",
        "state",
        "rooms",
        "legend",
        "from",
        "to",
        "objects",
        "target",
        "kb",
        "defaults",
        "search",
        "robot",
        "steps",
        "weight",
        "on",
        "occupancy",
        "robot_radius",
        "<<",
    ]
)
_SCALARS = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(-(10**6), 10**6),
    st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=12),
    st.sampled_from(["yes", "no", "on", "010", "1:30", ".nan", "-.inf", "1e308", "look", "scan", "#", "..#\n.#."]),
)
_VALUES = st.recursive(
    _SCALARS,
    lambda inner: st.one_of(
        st.lists(inner, max_size=4), st.dictionaries(st.one_of(_KEYS, st.text(max_size=6)), inner, max_size=5)
    ),
    max_leaves=25,
)


PER_EXAMPLE = timedelta(seconds=30)
"""A bound on each random file (a hang, not a speed measurement: each takes milliseconds)."""


@pytest.fixture(autouse=True)
def memory_bound() -> Iterator[None]:
    """Each test below runs with its address space bounded at 2 GiB above what the process holds:
    an input that makes a loader allocate more fails the test with a MemoryError."""
    if not Path("/proc/self/status").exists():  # pragma: no cover - not Linux
        yield
        return
    status = Path("/proc/self/status").read_text()
    held = int(next(line.split()[1] for line in status.splitlines() if line.startswith("VmSize:"))) * 1024
    soft, hard = resource.getrlimit(resource.RLIMIT_AS)
    bound = held + 2 * 1024**3
    resource.setrlimit(resource.RLIMIT_AS, (bound if hard == resource.RLIM_INFINITY else min(bound, hard), hard))
    try:
        yield
    finally:
        resource.setrlimit(resource.RLIMIT_AS, (soft, hard))


def _mutate(data: Any, path: list[int], value: Any) -> Any:
    """``data`` with the node picked by ``path`` (indices into its mappings' items and lists) replaced."""
    if not path:
        return value
    if isinstance(data, dict) and data:
        keys = list(data)
        key = keys[path[0] % len(keys)]
        return {**data, key: _mutate(data[key], path[1:], value)}
    if isinstance(data, list) and data:
        index = path[0] % len(data)
        return [*data[:index], _mutate(data[index], path[1:], value), *data[index + 1 :]]
    return value


BUNDLED_MAPS = sorted(p for p in MAPS.glob("*.yaml") if "depot" not in p.name and "tb3" not in p.name)
BUNDLED_DOMAINS = sorted(DOMAINS.glob("*.yaml"))


def _read_or_refuse(load: Any, path: Path) -> None:
    try:
        load(path)
    except BeliefLocError as exc:
        assert str(exc).strip(), "an error with no message"


@pytest.mark.slow
@settings(max_examples=150, deadline=PER_EXAMPLE, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    st.sampled_from(BUNDLED_MAPS),
    st.lists(st.integers(0, 50), max_size=5),
    _VALUES,
)
def test_a_mutated_map_loads_or_is_refused(tmp_path: Path, original: Path, where: list[int], value: Any):
    from beliefloc.semantic_map import compile_model, load_map

    data = _mutate(yaml.safe_load(original.read_text()), where, value)
    path = tmp_path / "mutated.yaml"
    path.write_text(yaml.safe_dump(data, allow_unicode=True))
    try:
        compile_model(load_map(path, on_warning=lambda message: None))
    except BeliefLocError as exc:
        assert str(exc).strip()


@pytest.mark.slow
@settings(max_examples=100, deadline=PER_EXAMPLE, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.sampled_from(BUNDLED_DOMAINS), st.lists(st.integers(0, 50), max_size=5), _VALUES)
def test_a_mutated_domain_loads_or_is_refused(tmp_path: Path, original: Path, where: list[int], value: Any):
    from beliefloc.knowledge import load_domain

    data = _mutate(yaml.safe_load(original.read_text()), where, value)
    path = DOMAINS.parent / "tests" / "data" / "fuzz" / f".mutated-{os.getpid()}.yaml"  # its kb: paths resolve
    try:
        path.write_text(yaml.safe_dump(data, allow_unicode=True))
        _read_or_refuse(load_domain, path)
    finally:
        path.unlink(missing_ok=True)


@pytest.fixture(scope="module")
def kitchen():
    from beliefloc.semantic_map import compile_model, load_map

    return compile_model(load_map(MAPS / "kitchen.yaml"))


@settings(max_examples=100, deadline=PER_EXAMPLE, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(_VALUES)
def test_a_random_belief_file_loads_or_is_refused(tmp_path: Path, kitchen, data: Any):
    from beliefloc.files.belief_file import load_belief

    path = tmp_path / "belief.yaml"
    path.write_text(yaml.safe_dump(data, allow_unicode=True))
    try:
        belief, _ = load_belief(kitchen, path)
    except BeliefLocError:
        return
    assert np.isfinite(belief).all() and (belief >= 0).all() and belief.sum() == pytest.approx(1.0)


_LOADERS = ("map", "domain", "belief", "model", "macros", "pomdp")


@settings(max_examples=120, deadline=PER_EXAMPLE, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.sampled_from(_LOADERS), st.binary(max_size=600))
def test_random_bytes_are_refused_by_every_loader(tmp_path: Path, kitchen, loader: str, raw: bytes):
    from beliefloc.files.belief_file import load_belief
    from beliefloc.files.macro_file import load_macros
    from beliefloc.files.model_file import load_model
    from beliefloc.knowledge import load_domain
    from beliefloc.pomdp_format import read_pomdp
    from beliefloc.semantic_map import load_map

    suffix = {"model": ".npz", "macros": ".npz", "pomdp": ".pomdp"}.get(loader, ".yaml")
    path = tmp_path / f"random{suffix}"
    path.write_bytes(raw)
    load = {
        "map": load_map,
        "domain": load_domain,
        "belief": lambda p: load_belief(kitchen, p),
        "model": load_model,
        "macros": lambda p: load_macros(p, kitchen),
        "pomdp": read_pomdp,
    }[loader]
    _read_or_refuse(load, path)
