"""Hostile input, third round (issue 30): the CLI's one boundary for failures from outside, and the
one reader for integers from outside.

Each case ends with exit 2 and one paragraph naming what was wrong, never a traceback.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from beliefloc.errors import LimitError
from beliefloc.source.limits import INPUT_BYTES, LARGEST_COUNT, read_count

from .conftest import MAPS, ROOT

APARTMENT = MAPS / "apartment.yaml"


def _run(
    *args: str, env: dict[str, str] | None = None, stdout: int | object = subprocess.PIPE
) -> subprocess.CompletedProcess[str]:
    full_env = {**os.environ, "PYTHONPATH": str(ROOT), **(env or {})}
    return subprocess.run(
        [sys.executable, "-m", "beliefloc", *args],
        stdout=stdout,  # type: ignore[arg-type]
        stderr=subprocess.PIPE,
        text=True,
        env=full_env,
        timeout=60,
        check=False,
    )


def _one_paragraph(result: subprocess.CompletedProcess[str]) -> str:
    assert result.returncode == 2, result.stderr
    assert "Traceback" not in result.stderr
    return result.stderr


@pytest.mark.parametrize("value", ["²", "1kB", "1e3", "-1", "0", "١٢", "1__0", "", "10" * 30])
def test_read_count_refuses_what_is_not_ascii_digits_in_range(value: str) -> None:
    with pytest.raises(ValueError, match="whole number from 1 to"):
        read_count(value, "X", lowest=1)


def test_read_count_reads_ascii_digits_with_underscores() -> None:
    assert read_count(" 1_000 ", "X") == 1000
    assert read_count(str(LARGEST_COUNT), "X") == LARGEST_COUNT


@pytest.mark.parametrize("value", ["²", "1kB", "1e3", "-1", "0", str(10**23)])
def test_a_garbage_limit_variable_is_refused_naming_it(value: str, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(INPUT_BYTES.variable, value)
    with pytest.raises(LimitError, match=INPUT_BYTES.variable):
        INPUT_BYTES.check(1, "a file")


def test_a_limit_variable_lowers_the_bound(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(INPUT_BYTES.variable, "1_000")
    with pytest.raises(LimitError, match="limit of 1,000"):
        INPUT_BYTES.check(1001, "a file")


@pytest.mark.parametrize(
    ("variable", "args"),
    [
        ("BELIEFLOC_MAX_INPUT_BYTES", ("validate", str(APARTMENT))),
        ("BELIEFLOC_MAX_MODEL_ENTRIES", ("validate", str(APARTMENT))),
        ("BELIEFLOC_MAX_KB_SECONDS", ("kb", "check", str(ROOT / "domains" / "home.yaml"))),
    ],
)
@pytest.mark.parametrize("value", ["²", str(10**23)])
def test_a_garbage_limit_variable_on_the_command_line(variable: str, args: tuple[str, ...], value: str) -> None:
    message = _one_paragraph(_run(*args, env={variable: value}))
    assert variable in message
    assert "line" not in message  # not blamed on the map


@pytest.mark.parametrize("args", [("validate", str(APARTMENT)), ("--help",), ("show", str(APARTMENT))])
def test_a_full_stdout_is_one_paragraph(args: tuple[str, ...]) -> None:
    with open("/dev/full", "w") as full:
        message = _one_paragraph(_run(*args, stdout=full))
    assert "cannot write the output" in message


def test_huge_counts_on_the_command_line_are_refused_naming_the_option(tmp_path: Path) -> None:
    huge = str(2**200)
    message = _one_paragraph(_run("simulate", str(APARTMENT), "-n", huge))
    assert "--episodes" in message and "out of range" in message
    message = _one_paragraph(
        _run("simulate", str(APARTMENT), "-n", "1", "--record", str(tmp_path / "a.gif"), "--record-frames", huge)
    )
    assert "--record-frames" in message and "positive integer" in message


@pytest.mark.parametrize("start", ["1" * 5000 + ",1", "١,١", "１,１"])
def test_a_start_that_is_not_ascii_digits_is_an_unknown_state(start: str) -> None:
    message = _one_paragraph(_run("simulate", str(APARTMENT), "-n", "1", "--start", start))
    assert "unknown state" in message
    assert len(message) < 2000


def test_outside_failure_keeps_bugs() -> None:
    from beliefloc.cli.common import outside_failure

    assert outside_failure(KeyError("x")) is None
    assert outside_failure(ValueError("a bug")) is None
    assert outside_failure(OSError(28, "No space left on device", "some-file")) is None
    assert outside_failure(OSError(28, "No space left on device")) is not None
    assert outside_failure(OverflowError("int too large")) is not None
    from rich.errors import MarkupError

    assert outside_failure(MarkupError("closing tag '[/]' has nothing to close")) is not None


# --- results files -----------------------------------------------------------------------------------

RESULTS = ROOT / "tests" / "data" / "fuzz" / "results"


@pytest.mark.parametrize("path", sorted(RESULTS.glob("*.jsonl")), ids=lambda p: p.name)
def test_a_damaged_results_file_is_refused_before_any_work(path: Path) -> None:
    result = _run("summarize", str(path))
    if path.name.startswith("strategy_markup"):
        assert result.returncode == 0, result.stderr
        assert "[/]" in result.stdout  # shown as written, never read as markup
        return
    message = _one_paragraph(result)
    assert str(path) in message
    assert "\x1b" not in message


def test_a_strategy_written_as_markup_is_shown_as_text(tmp_path: Path) -> None:
    source = (RESULTS / "strategy_markup_close.jsonl").read_text()
    path = tmp_path / "bold.jsonl"
    path.write_text(source.replace('"strategy":"[/]"', '"strategy":"[bold red]x"'))
    result = _run("summarize", str(path), env={"TERM": "xterm-256color", "FORCE_COLOR": "1"})
    assert result.returncode == 0, result.stderr
    assert "[bold red]x" in result.stdout


@pytest.mark.parametrize("name", ["cost_text.jsonl", "no_records.jsonl", "total_text.jsonl"])
def test_resume_refuses_a_damaged_file_without_appending(name: str, tmp_path: Path) -> None:
    path = tmp_path / name
    path.write_bytes((RESULTS / name).read_bytes())
    before = path.read_bytes()
    args = ("simulate", str(MAPS / "kitchen.yaml"), "-n", "3", "--no-timings", "--out", str(path), "--resume")
    message = _one_paragraph(_run(*args))
    assert str(path) in message
    assert path.read_bytes() == before


# --- localize ----------------------------------------------------------------------------------------

WINDOW = MAPS / "window-2x2-perfect.yaml"


def test_a_silent_robot_is_given_up_naming_the_action() -> None:
    robot = subprocess.Popen(["sleep", "30"], stdout=subprocess.PIPE)  # never writes, never closes
    try:
        result = subprocess.run(
            [sys.executable, "-m", "beliefloc", "localize", str(WINDOW), "--quiet", "--reply-timeout", "0.5"],
            stdin=robot.stdout,
            capture_output=True,
            text=True,
            env={**os.environ, "PYTHONPATH": str(ROOT)},
            timeout=30,
            check=False,
        )
    finally:
        robot.kill()
        robot.wait()
    message = _one_paragraph(result)
    assert "no reply to action 1 (look) within 0.5 s (--reply-timeout)" in message


@pytest.mark.parametrize("reply", ['{"seq": 1, "readings": {"look": [' + "9" * 311 + "]}}"])
def test_a_311_digit_integer_in_a_reply_is_refused(reply: str) -> None:
    result = subprocess.run(
        [sys.executable, "-m", "beliefloc", "localize", str(WINDOW), "--quiet"],
        input=reply + "\n",
        capture_output=True,
        text=True,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
        timeout=60,
        check=False,
    )
    message = _one_paragraph(result)
    assert "311-digit integer" in message


# --- sweeps ------------------------------------------------------------------------------------------

KITCHEN = MAPS / "kitchen.yaml"


def test_workers_are_capped_with_a_note() -> None:
    result = _run("simulate", str(KITCHEN), "-n", "2", "--workers", "100000")
    assert result.returncode == 0, result.stderr
    assert "--workers 100,000: capped at" in result.stderr


def test_pool_size_is_bounded_by_units_and_cores() -> None:
    from beliefloc.simulation.sweep import WORKERS_PER_CORE, cores, pool_size

    assert pool_size(100_000, 2) == (2, pool_size(100_000)[1])
    size, note = pool_size(100_000)
    assert size == WORKERS_PER_CORE * cores() and note is not None
    assert pool_size(2, 100) == (2, None)


@pytest.mark.parametrize("address", ["tcp://[::1:8786", "tcp://host:99999", "nonsense"])
def test_a_malformed_scheduler_address_is_refused(address: str) -> None:
    message = _one_paragraph(_run("simulate", str(KITCHEN), "-n", "2", "--scheduler", address))
    assert "not a scheduler address" in message


_SILENT_SERVER = """
import socket, struct, sys
server = socket.socket()
server.bind(("127.0.0.1", 0))
server.listen(5)
print(server.getsockname()[1], flush=True)
held = []
while True:
    connection, _ = server.accept()
    held.append(connection)
    if sys.argv[1] == "huge":
        connection.sendall(struct.pack("<QQQ", 3_500_000_000, 1, 3_499_999_984))
"""


@pytest.mark.slow
@pytest.mark.parametrize("mode", ["silent", "huge"])
def test_a_scheduler_that_never_speaks_is_given_up(mode: str) -> None:
    pytest.importorskip("distributed")
    server = subprocess.Popen([sys.executable, "-c", _SILENT_SERVER, mode], stdout=subprocess.PIPE, text=True)
    try:
        assert server.stdout is not None
        port = server.stdout.readline().strip()
        message = _one_paragraph(_run("simulate", str(KITCHEN), "-n", "2", "--scheduler", f"tcp://127.0.0.1:{port}"))
    finally:
        server.kill()
        server.wait()
    assert ("said nothing within" if mode == "silent" else "3,500,000,000 bytes") in message


def _children(pid: int) -> list[int]:
    path = Path(f"/proc/{pid}/task/{pid}/children")
    return [int(p) for p in path.read_text().split()] if path.exists() else []


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (FileNotFoundError, IndexError):
        return False
    return state != "Z"


@pytest.mark.slow
@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_sigterm_ends_the_pool_with_its_parent(tmp_path: Path) -> None:
    import signal
    import time

    sweep = subprocess.Popen(
        [sys.executable, "-m", "beliefloc", "simulate", str(KITCHEN), "-n", "4000", "--workers", "2"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
    )
    try:
        deadline = time.monotonic() + 30
        workers: list[int] = []
        while time.monotonic() < deadline and len(workers) < 2:
            time.sleep(0.2)
            workers = [p for p in _children(sweep.pid) if _alive(p)]
        assert len(workers) >= 2, "the pool did not start"
        sweep.send_signal(signal.SIGTERM)
        sweep.wait(timeout=20)
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline and any(_alive(p) for p in workers):
            time.sleep(0.2)
        assert not any(_alive(p) for p in workers), "workers outlived their parent"
    finally:
        if sweep.poll() is None:
            sweep.kill()
            sweep.wait()


@pytest.mark.slow
@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_sigkill_of_the_parent_ends_its_workers() -> None:
    import signal
    import time

    sweep = subprocess.Popen(
        [sys.executable, "-m", "beliefloc", "simulate", str(KITCHEN), "-n", "4000", "--workers", "2"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
    )
    deadline = time.monotonic() + 30
    workers: list[int] = []
    while time.monotonic() < deadline and len(workers) < 2:
        time.sleep(0.2)
        workers = [p for p in _children(sweep.pid) if _alive(p)]
    sweep.send_signal(signal.SIGKILL)
    sweep.wait()
    assert len(workers) >= 2, "the pool did not start"
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline and any(_alive(p) for p in workers):
        time.sleep(0.2)
    assert not any(_alive(p) for p in workers), "workers outlived their parent"


def _wait_for_lines(path: Path, lines: int, seconds: float = 30) -> None:
    import time

    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        if path.exists() and path.read_bytes().count(b"\n") >= lines:
            return
        time.sleep(0.1)
    raise AssertionError(f"{path} did not get {lines} lines")


@pytest.mark.slow
def test_a_second_sweep_on_the_same_results_file_is_refused_naming_the_first(tmp_path: Path) -> None:
    out = tmp_path / "r.jsonl"
    args = [
        sys.executable,
        "-m",
        "beliefloc",
        "simulate",
        str(KITCHEN),
        "-n",
        "3000",
        "--no-timings",
        "--out",
        str(out),
    ]
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    first = subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env)
    try:
        _wait_for_lines(out, 2)
        message = _one_paragraph(_run(*args[3:], "--resume"))
        assert f"pid {first.pid}" in message
    finally:
        first.kill()
        first.wait()
    # the file the first wrote is whole: every line parses and the units are in order
    from beliefloc.files.results_file import read_results

    content = read_results(out)
    assert len(content.results) >= 1


@pytest.mark.slow
def test_a_results_file_removed_during_the_run_is_reported(tmp_path: Path) -> None:
    import shutil

    folder = tmp_path / "runs"
    folder.mkdir()
    out = folder / "r.jsonl"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    sweep = subprocess.Popen(
        [sys.executable, "-m", "beliefloc", "simulate", str(KITCHEN), "-n", "400", "--no-timings", "--out", str(out)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
    )
    _wait_for_lines(out, 2)
    shutil.rmtree(folder)
    _, stderr = sweep.communicate(timeout=120)
    assert sweep.returncode == 2, stderr
    assert "removed or replaced during the run" in stderr and "Traceback" not in stderr


# --- belief files ------------------------------------------------------------------------------------

BELIEFS = ROOT / "tests" / "data" / "fuzz" / "beliefs"


@pytest.mark.parametrize(
    ("name", "expected"),
    [
        ("bool_probability.json", "got true (a boolean)"),
        ("text_probability.json", "got '0.5'"),
        ("arabic_indic_digits.json", "unknown state"),
        ("fullwidth_digits.json", "unknown state"),
        ("escape_in_key.json", "\\x1b[2J1,1,0"),
        ("long_key.json", "unknown state 'xxxx"),  # read by json: no YAML syntax error
    ],
)
def test_a_belief_file_reads_numbers_and_ascii_states_only(name: str, expected: str) -> None:
    message = _one_paragraph(_run("pose", str(APARTMENT), "--belief", str(BELIEFS / name)))
    assert expected in message
    assert "\x1b" not in message and "\x07" not in message


def test_a_map_key_with_terminal_escapes_is_shown_escaped(tmp_path: Path) -> None:
    path = tmp_path / "m.yaml"
    path.write_text(APARTMENT.read_text() + '"\\e[2J\\e]0;title\\a": 1\n')
    message = _one_paragraph(_run("validate", str(path)))
    assert "\\x1b[2J" in message and "\x1b" not in message and "\x07" not in message


# --- clearer messages --------------------------------------------------------------------------------

FUZZ = ROOT / "tests" / "data" / "fuzz"


def test_an_absurd_occupancy_resolution_is_named_on_its_line(tmp_path: Path) -> None:
    import shutil

    shutil.copy(MAPS / "occupancy" / "depot.pgm", tmp_path / "depot.pgm")
    shutil.copy(FUZZ / "occupancy" / "resolution-1e300.yaml", tmp_path / "depot.yaml")
    text = (
        (MAPS / "depot.yaml")
        .read_text()
        .replace("occupancy: occupancy/depot.yaml", f"occupancy: {tmp_path}/depot.yaml")
    )
    (tmp_path / "map.yaml").write_text(text)
    message = _one_paragraph(_run("validate", str(tmp_path / "map.yaml")))
    assert "resolution" in message and "cell_size" not in message


def test_a_pomdp_file_with_cr_only_line_endings_is_read() -> None:
    result = _run("inspect", str(ROOT / "tests" / "data" / "pomdp" / "cr-only-line-endings.pomdp"), "--json")
    assert result.returncode == 0, result.stderr
