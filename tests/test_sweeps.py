"""Sweeps (issue 17): the same bytes on every backend (one process, a process pool, a Dask cluster),
results files that survive a kill and resume, ``summarize``, and the bad inputs that must not
start (or overwrite) anything. No timing assertions: the speed is the benchmark's
(benchmarks/bench_sweeps.py)."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from beliefloc.cli.app import app
from beliefloc.files.results_file import differences, header, read_results
from beliefloc.simulation import sweep as sweeps

from .conftest import ROOT

KITCHEN = str(ROOT / "maps" / "kitchen.yaml")
HOME = str(ROOT / "domains" / "home.yaml")
SIMULATE = ["simulate", KITCHEN, "-n", "12", "-s", "bestfirst", "-s", "random", "--seed", "3"]
SEARCH = ["search", "simulate", HOME, "-n", "8", "-m", "none,expectation", "--absent-fraction", "0.5", "--seed", "2"]
SWEEPS = {"simulate": SIMULATE, "search": SEARCH}


def _run(runner, args: list[str], code: int = 0) -> str:
    result = runner.invoke(app, args)
    assert result.exit_code == code, result.output + str(result.exception)
    return result.stdout


# --- the same bytes on every backend ---------------------------------------------------------------


@pytest.fixture(scope="module")
def cluster() -> Iterator[str]:
    """A Dask LocalCluster of two worker processes on the loopback interface."""
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1", dashboard_address=None
    ) as local:
        yield local.scheduler_address


@pytest.mark.parametrize("name", list(SWEEPS))
def test_one_process_and_a_pool_print_the_same_bytes(runner, tmp_path: Path, name: str):
    args = [*SWEEPS[name], "--json", "--no-timings"]
    one = _run(runner, [*args, "--out", str(tmp_path / "one.jsonl")])
    pool = _run(runner, [*args, "--workers", "2", "--out", str(tmp_path / "pool.jsonl")])
    assert one == pool
    assert (tmp_path / "one.jsonl").read_bytes() == (tmp_path / "pool.jsonl").read_bytes()
    assert json.loads(one)["summary"]


@pytest.mark.slow
@pytest.mark.parametrize("name", list(SWEEPS))
def test_a_dask_cluster_prints_the_same_bytes(runner, tmp_path: Path, cluster: str, name: str):
    args = [*SWEEPS[name], "--json", "--no-timings"]
    one = _run(runner, [*args, "--out", str(tmp_path / "one.jsonl")])
    dask = _run(runner, [*args, "--scheduler", cluster, "--out", str(tmp_path / "dask.jsonl")])
    assert one == dask
    assert (tmp_path / "one.jsonl").read_bytes() == (tmp_path / "dask.jsonl").read_bytes()


def test_the_json_of_a_sweep_is_todays(runner):
    """Going through the sweep machinery changed nothing in what ``simulate --json`` prints."""
    from beliefloc.cli.common import open_model
    from beliefloc.simulation.episode import run_experiment

    records = run_experiment(open_model(Path(KITCHEN)), ["bestfirst", "random"], episodes=12, seed=3)
    printed = json.loads(_run(runner, [*SIMULATE, "--json", "--no-timings"]))
    assert printed["episodes"] == json.loads(json.dumps([r.as_json(timings=False) for r in records]))


def test_chunks_cover_every_unit_once_in_order_larger_first():
    for total in (0, 1, 7, 100, 1000):
        for workers in (1, 2, 5):
            parts = sweeps.chunks(list(range(total)), workers)
            assert [i for part in parts for i in part] == list(range(total))
            sizes = [len(part) for part in parts]
            assert sizes == sorted(sizes, reverse=True)
            assert all(0 < size <= sweeps.MAX_CHUNK for size in sizes)


def test_results_are_put_back_in_order():
    pairs = [(2, {"k": 2}), (0, {"k": 0}), (3, {"k": 3}), (1, {"k": 1})]
    assert [i for i, _ in sweeps.in_order(pairs, [0, 1, 2, 3])] == [0, 1, 2, 3]
    with pytest.raises(sweeps.SweepError, match="no result for unit 1"):
        list(sweeps.in_order([(0, {})], [0, 1]))


class _Echo:
    def runner(self) -> sweeps.Runner:
        return lambda index: {"index": index}


def test_a_worker_of_another_version_refuses_the_work():
    with pytest.raises(sweeps.VersionMismatchError, match=r"a worker runs beliefloc .* but the client runs 0\.0\.0"):
        sweeps.run_chunk(_Echo(), "0.0.0", [0])
    assert sweeps.run_chunk(_Echo(), sweeps.__version__, [4, 5]).results == [(4, {"index": 4}), (5, {"index": 5})]


def test_a_pool_of_another_version_is_exit_2(runner, monkeypatch):
    """The client's version travels with every chunk; the pool's workers (this installation) refuse it."""
    monkeypatch.setattr(sweeps, "__version__", "0.0.0-other")
    # spawned workers import this installation; a forked one would inherit the patched version (the
    # pool forks when no other thread runs, which depends on the tests that ran before this one)
    monkeypatch.setattr(sweeps.PoolBackend, "start_method", lambda self: "spawn")
    result = runner.invoke(app, [*SIMULATE, "--workers", "2"])
    assert result.exit_code == 2, result.output
    assert "but the client runs 0.0.0-other" in result.stderr


# --- results files: kill, resume, summarize --------------------------------------------------------

KILLED = ["search", "simulate", HOME, "-n", "150", "-m", "none,expectation", "--json", "--no-timings"]


def _cli(args: list[str], **kwargs) -> subprocess.Popen[bytes]:
    env = {**os.environ, "COLUMNS": "120"}
    return subprocess.Popen([sys.executable, "-m", "beliefloc", *args], env=env, **kwargs)


@pytest.mark.slow
def test_a_killed_sweep_resumes_to_the_same_bytes(tmp_path: Path):
    """SIGKILL half way, ``--resume`` (on two workers, even): the file and the output are those of a
    run that was never interrupted."""
    whole = subprocess.run(
        [sys.executable, "-m", "beliefloc", *KILLED, "--out", str(tmp_path / "whole.jsonl")],
        capture_output=True,
        check=True,
    )
    killed = tmp_path / "killed.jsonl"
    process = _cli([*KILLED, "--out", str(killed)], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and process.poll() is None:
        if killed.exists() and killed.read_bytes().count(b"\n") >= 20:
            break
        time.sleep(0.005)
    assert process.poll() is None, "the run ended before it could be killed"
    process.send_signal(signal.SIGKILL)
    process.wait()
    lines = killed.read_bytes().count(b"\n")
    assert 20 <= lines < 151
    resumed = subprocess.run(
        [sys.executable, "-m", "beliefloc", *KILLED, "--out", str(killed), "--resume", "--workers", "2"],
        capture_output=True,
        check=True,
    )
    assert killed.read_bytes() == (tmp_path / "whole.jsonl").read_bytes()
    assert resumed.stdout == whole.stdout


def test_a_torn_last_line_is_dropped_and_redone(runner, tmp_path: Path):
    whole, torn = tmp_path / "whole.jsonl", tmp_path / "torn.jsonl"
    args = [*SIMULATE, "--json", "--no-timings"]
    printed = _run(runner, [*args, "--out", str(whole)])
    data = whole.read_bytes()
    cut = data.rstrip(b"\n").rfind(b"\n") + 40  # 40 bytes into the last line
    torn.write_bytes(data[:cut])
    found = read_results(torn)
    assert found.torn and len(found.results) == 11
    result = runner.invoke(app, [*args, "--out", str(torn), "--resume"])
    assert result.exit_code == 0
    assert "last line was cut short" in result.stderr
    assert torn.read_bytes() == data
    assert result.stdout == printed


def test_resume_with_other_settings_is_refused_naming_the_difference(runner, tmp_path: Path):
    out = tmp_path / "run.jsonl"
    _run(runner, [*SIMULATE, "--no-timings", "--out", str(out)])
    before = out.read_bytes()
    other = [*SIMULATE[:-1], "4", "--no-timings", "--out", str(out), "--resume"]  # --seed 4
    result = runner.invoke(app, other)
    assert result.exit_code == 2
    assert "settings.seed: 3 in the file, 4 now" in " ".join(result.stderr.split())
    result = runner.invoke(app, [*SIMULATE, "--out", str(out), "--resume"])  # with timings this time
    assert result.exit_code == 2
    assert "settings.timings: false in the file, true now" in " ".join(result.stderr.split())
    assert out.read_bytes() == before


def test_a_finished_file_resumes_to_nothing_new(runner, tmp_path: Path):
    out = tmp_path / "run.jsonl"
    args = [*SEARCH, "--json", "--no-timings", "--out", str(out)]
    first = _run(runner, args)
    before = out.read_bytes()
    assert _run(runner, [*args, "--resume"]) == first
    assert out.read_bytes() == before


def test_the_file_holds_a_header_and_a_line_per_unit_without_clocks(runner, tmp_path: Path):
    out = tmp_path / "run.jsonl"
    _run(runner, [*SIMULATE, "--no-timings", "--out", str(out)])
    lines = out.read_text().splitlines()
    head = json.loads(lines[0])
    assert head["format"] == "beliefloc-results" and head["command"] == "simulate" and head["total"] == 12
    assert [json.loads(line)["episode"] for line in lines[1:]] == list(range(12))
    records = [record for line in lines[1:] for record in json.loads(line)["records"]]
    assert all(record["plan_seconds"] is None for record in records)  # no clock value


@pytest.mark.parametrize("name", list(SWEEPS))
def test_summarize_prints_the_runs_summary(runner, tmp_path: Path, name: str):
    out = tmp_path / "run.jsonl"
    printed = json.loads(_run(runner, [*SWEEPS[name], "--json", "--out", str(out)]))
    summary = json.loads(_run(runner, ["summarize", str(out), "--json"]))
    assert summary["summary"] == printed["summary"]
    assert (summary["done"], summary["total"]) == (len(out.read_text().splitlines()) - 1,) * 2
    table = _run(runner, [*SWEEPS[name], "--resume", "--out", str(out)])  # nothing to run: prints the table
    assert _run(runner, ["summarize", str(out)]) == table


def test_summarize_reads_a_file_being_written(runner, tmp_path: Path):
    out = tmp_path / "run.jsonl"
    _run(runner, [*SIMULATE, "--out", str(out)])
    lines = out.read_bytes().splitlines(keepends=True)
    out.write_bytes(b"".join(lines[:5]) + lines[5][:30])
    result = runner.invoke(app, ["summarize", str(out), "--json"])
    assert result.exit_code == 0
    assert (json.loads(result.stdout)["done"], json.loads(result.stdout)["total"]) == (4, 12)
    assert "4 of 12 episodes so far" in result.stderr


def test_differences_name_nested_keys():
    a = header("simulate", "episode", 3, {"seed": 0, "files": {"a": "1"}})
    b = header("simulate", "episode", 4, {"seed": 0, "files": {"a": "2"}, "gamma": None})
    assert differences(a, b) == [
        "total: 3 in the file, 4 now",
        'settings.files.a: "1" in the file, "2" now',
        "settings.gamma: absent in the file, null now",
    ]


# --- bad input ---------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--workers", "-1"], "--workers"),
        (["--workers", "nan"], "--workers"),
        (["--resume"], "--resume: needs --out"),
        (["--out", "x.txt"], "unknown kind of file"),
        (["--workers", "2", "--scheduler", "tcp://127.0.0.1:9"], "give one of them"),
        (["--scheduler", "tcp://127.0.0.1:9"], "cannot reach the Dask scheduler"),
        (["--scheduler", "nowhere"], "not a scheduler address"),
    ],
)
@pytest.mark.parametrize("name", list(SWEEPS))
def test_bad_sweep_options_are_exit_2(runner, tmp_path: Path, monkeypatch, name: str, extra: list[str], message):
    _refused(runner, tmp_path, monkeypatch, [*SWEEPS[name], *extra], message)


@pytest.mark.parametrize("where", [["--workers", "2"], ["--workers", "0"], ["--scheduler", "tcp://127.0.0.1:9"]])
@pytest.mark.parametrize("option", [["--show"], ["--record", "e.gif"]])
def test_show_and_record_need_this_process(runner, tmp_path: Path, monkeypatch, where, option):
    _refused(runner, tmp_path, monkeypatch, [*SIMULATE, *option, *where], f"{option[0]}: draws every step in this")


def _refused(runner, tmp_path: Path, monkeypatch, args: list[str], message: str) -> None:
    monkeypatch.chdir(tmp_path)
    started = time.monotonic()
    result = runner.invoke(app, args)
    assert result.exit_code == 2, result.output
    assert message in " ".join(result.stderr.split())
    assert "Traceback" not in result.output
    assert time.monotonic() - started < 10 + 5  # not a hang (the issue: an error within 10 s)
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize("name", list(SWEEPS))
def test_an_out_file_that_is_not_a_results_file_is_left_alone(runner, tmp_path: Path, name: str):
    other = tmp_path / "notes.jsonl"
    other.write_text('{"mine": 1}\n')
    for extra in ([], ["--resume"]):
        result = runner.invoke(app, [*SWEEPS[name], "--out", str(other), *extra])
        assert result.exit_code == 2, result.output
        assert "not a beliefloc results file" in " ".join(result.stderr.split())
    assert other.read_text() == '{"mine": 1}\n'
    result = runner.invoke(app, ["summarize", str(other)])
    assert result.exit_code == 2 and "not a beliefloc results file" in " ".join(result.stderr.split())


def test_a_scheduler_without_dask_names_the_install_line(runner, monkeypatch):
    monkeypatch.setitem(sys.modules, "distributed", None)  # import distributed: ImportError
    result = runner.invoke(app, [*SIMULATE, "--scheduler", "tcp://127.0.0.1:8786"])
    assert result.exit_code == 2
    assert "pip install 'beliefloc[dask]'" in " ".join(result.stderr.split())


def test_record_with_resume_is_refused(runner, tmp_path: Path):
    result = runner.invoke(
        app, [*SIMULATE, "--record", str(tmp_path / "e.gif"), "--out", str(tmp_path / "r.jsonl"), "--resume"]
    )
    assert result.exit_code == 2
    assert "--resume may not run the recorded episode again" in " ".join(result.stderr.split())
