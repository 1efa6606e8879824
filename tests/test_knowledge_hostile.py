"""Hostile knowledge bases and domains: each is refused with one paragraph naming the file, the line
and the cause (exit 2), or stopped by a budget -- never a traceback, a clingo PANIC, a hang.

The corpus is tests/data/fuzz/kb/ (``.lp`` files, one per cause) and tests/data/fuzz/domains/
(domain files, one per cause). Budgets are lowered through their environment variables to prove
that they stop a bomb; no test asserts how long anything takes.
"""

from __future__ import annotations

import math
import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest
from typer.testing import CliRunner

from beliefloc.cli.app import app
from beliefloc.errors import EXIT_BAD_INPUT, DomainError, InvalidValueError, KnowledgeBaseError, LimitError
from beliefloc.knowledge import KnowledgeBase, Observation, domain_from_data, load_domain, room_prior
from beliefloc.knowledge import program as program_module
from beliefloc.knowledge.domain import (
    Default,
    ObjectInstance,
    _overlapping,
    _Strict,
    aliased_fields,
)
from beliefloc.knowledge.files import directives
from beliefloc.object_search.settings import check_time_limit

from .conftest import DATA, ROOT

FUZZ_KB = DATA / "fuzz" / "kb"
FUZZ_DOMAINS = DATA / "fuzz" / "domains"
HOME = ROOT / "domains" / "home.yaml"
PRINTER = ROOT / "domains" / "printer-example.yaml"


def refused(out: Any) -> str:
    """The CLI refused: exit 2, one error on stderr, no traceback, no clingo panic; the message."""
    assert out.exit_code == EXIT_BAD_INPUT, out.output
    assert "Traceback" not in out.output and "PANIC" not in out.output, out.output
    assert out.stdout == "", out.stdout
    return " ".join(out.stderr.split())


def small(**extra: Any) -> dict[str, Any]:
    return {"name": "small", "rooms": ["kitchen", "study"], "classes": {"object": None, "book": "object"}, **extra}


def write(path: Path, text: str | bytes) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    if isinstance(text, bytes):
        path.write_bytes(text)
    else:
        path.write_text(text)
    return path


# -- 1. files clingo must not see: not UTF-8, not a program, too large -------------------------------


@pytest.mark.parametrize(
    ("name", "message"),
    [
        ("not_utf8.lp", r"not_utf8\.lp:1: not UTF-8 text"),
        ("non_ascii_name.lp", r"non_ascii_name\.lp:2:7: 'é' is not ASCII"),
        ("script_python.lp", r"script_python\.lp:3:1: #script: beliefloc does not run code"),
        ("script_lua.lp", r"script_lua\.lp:2:1: #script: beliefloc does not run code"),
        ("include_incmode.lp", r"include_incmode\.lp:2:1: #include <incmode>: .*a Lua script"),
        ("theory.lp", r"theory\.lp:2:1: #theory: theory definitions are not supported"),
        ("include_parent.lp", r'include_parent\.lp:2:1: #include "\.\./outside\.lp": is outside the folder'),
        ("include_absolute.lp", r'include_absolute\.lp:2:1: #include "/etc/hostname": is an absolute path'),
        ("include_missing.lp", r'include_missing\.lp:2:1: #include "nowhere\.lp": \S*nowhere\.lp: no such'),
        ("include_folder.lp", r'include_folder\.lp:2:1: #include "includes": \S*includes: is a folder'),
        ("include_malformed.lp", r"include_malformed\.lp:2:1: #include: write the file name in quotes"),
        ("include_broken.lp", r"includes/broken\.lp:3:1: syntax error"),
    ],
)
def test_every_hostile_kb_is_refused_with_its_line(name: str, message: str, runner: CliRunner) -> None:
    with pytest.raises(KnowledgeBaseError, match=message):
        KnowledgeBase(load_domain(PRINTER), [FUZZ_KB / name])
    text = refused(runner.invoke(app, ["kb", "check", str(PRINTER), "--kb", str(FUZZ_KB / name)]))
    assert "error: " in text and "beliefloc-kb-" not in text  # the private copies are never named


def test_every_kb_corpus_file_has_a_case() -> None:
    cases = {
        "not_utf8.lp", "non_ascii_name.lp", "script_python.lp", "script_lua.lp", "include_incmode.lp", "theory.lp",
        "include_parent.lp", "include_absolute.lp", "include_missing.lp", "include_folder.lp",
        "include_malformed.lp", "include_broken.lp", "bomb_memory.lp", "bomb_time.lp", "include_self.lp",
        "include_nested.lp", "included_up.lp", "commented.lp", "includes/inner.lp", "includes/broken.lp",
    }  # fmt: skip
    assert {str(p.relative_to(FUZZ_KB)) for p in FUZZ_KB.rglob("*.lp")} == cases


def test_a_markdown_file_as_kb_is_refused_without_a_panic(runner: CliRunner, tmp_path: Path) -> None:
    """The README case: UTF-8 text with non-ASCII characters, not a program. clingo's lexer error
    quoted half a character, which its Python binding could not decode: PANIC."""
    notes = write(tmp_path / "NOTES.md", "# Notes\n\nA grid of 3 × 4 cells — see the map.\n")
    text = refused(runner.invoke(app, ["kb", "check", str(HOME), "--kb", str(notes)]))
    assert f"{notes}:3:13: '×' is not ASCII" in text
    assert f"is {notes} a knowledge base? --kb and kb: take ASP programs" in text
    readme = refused(runner.invoke(app, ["kb", "check", str(HOME), "--kb", str(ROOT / "README.md")]))
    assert "README.md" in readme


def test_a_latin1_file_names_its_line(runner: CliRunner, tmp_path: Path) -> None:
    legacy = write(tmp_path / "legacy.txt", b"% notes\n% more\nis(caf\xe9, book).\n")
    text = refused(runner.invoke(app, ["kb", "check", str(HOME), "--kb", str(legacy)]))
    assert f"{legacy}:3: not UTF-8 text" in text and "knowledge base?" in text


def test_a_yaml_file_as_kb_gets_a_hint(runner: CliRunner) -> None:
    text = refused(runner.invoke(app, ["kb", "check", str(HOME), "--kb", str(PRINTER)]))
    assert "printer-example.yaml:1:" in text and "a knowledge base? --kb and kb: take ASP programs" in text


def test_other_kinds_of_file_are_named(runner: CliRunner, tmp_path: Path) -> None:
    model = write(tmp_path / "kitchen.npz", b"PK\x03\x04")
    text = refused(runner.invoke(app, ["kb", "check", str(HOME), "--kb", str(model)]))
    assert f"{model} is a compiled model or macro table (.npz), not a knowledge base (.lp)" in text


def test_a_nul_character_is_refused(tmp_path: Path) -> None:
    odd = write(tmp_path / "odd.lp", b"is(a, book).\nis(b\x00, book).\n")
    with pytest.raises(KnowledgeBaseError, match=r"odd\.lp:2: a NUL character"):
        KnowledgeBase(load_domain(PRINTER), [odd])


def test_the_files_of_a_kb_are_read_within_the_input_limit(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    big = write(tmp_path / "big.lp", "".join(f"is(o{i}, book).\n" for i in range(200)))
    monkeypatch.setenv("BELIEFLOC_MAX_INPUT_BYTES", "1000")
    with pytest.raises(LimitError, match="BELIEFLOC_MAX_INPUT_BYTES"):
        KnowledgeBase(load_domain(PRINTER), [big])


def test_special_files_are_refused_before_reading(tmp_path: Path, runner: CliRunner) -> None:
    """A FIFO would block, /dev/zero never end: both refused, as --kb, as kb: and through #include."""
    fifo = tmp_path / "pipe.lp"
    os.mkfifo(fifo)
    text = refused(runner.invoke(app, ["kb", "check", str(HOME), "--kb", str(fifo)]))
    assert f"{fifo}: is a named pipe (FIFO), not a regular file" in text
    text = refused(runner.invoke(app, ["kb", "check", str(HOME), "--kb", "/dev/zero"]))
    assert "/dev/zero: is a character device (like /dev/zero or a terminal), not a regular file" in text
    write(tmp_path / "via.lp", '#include "pipe.lp".\n')
    with pytest.raises(KnowledgeBaseError, match=r'via\.lp:1:1: #include "pipe\.lp": \S*pipe\.lp: is a named pipe'):
        KnowledgeBase(load_domain(PRINTER), [tmp_path / "via.lp"])
    domain = write(tmp_path / "d.yaml", "name: d\nrooms: [kitchen]\nclasses: {object: null}\nkb: [pipe.lp]\n")
    with pytest.raises(DomainError, match=r"d\.yaml:4:6: kb\[0\]: pipe\.lp: is a named pipe"):
        load_domain(domain)
    (tmp_path / "zero.lp").symlink_to("/dev/zero")  # a link out of the folder: outside, and a device
    zero = write(tmp_path / "z.yaml", "name: z\nrooms: [kitchen]\nclasses: {object: null}\nkb: [zero.lp]\n")
    with pytest.raises(DomainError, match=r"z\.yaml:4:6: kb\[0\]: zero\.lp is outside the folder"):
        load_domain(zero)
    with pytest.raises(DomainError, match=r"z\.yaml:4:6: kb\[0\]: zero\.lp: is a character device"):
        load_domain(zero, allow_outside=True)


# -- 2. the budget of grounding and solving ------------------------------------------------------------


@pytest.mark.slow
def test_a_memory_bomb_is_stopped_by_the_memory_budget(monkeypatch: pytest.MonkeyPatch, runner: CliRunner) -> None:
    """n(0..100000000). grows to gigabytes; under a 300 MB budget it stops, naming the budget."""
    monkeypatch.setenv("BELIEFLOC_MAX_KB_BYTES", "300000000")
    with pytest.raises(LimitError, match=r"300,000,000 bytes of memory.*BELIEFLOC_MAX_KB_BYTES=N"):
        KnowledgeBase(load_domain(PRINTER), [FUZZ_KB / "bomb_memory.lp"])
    text = refused(runner.invoke(app, ["prior", str(PRINTER), "--kb", str(FUZZ_KB / "bomb_memory.lp")]))
    assert "printer-example.yaml (with " in text and "bomb_memory.lp): grounding and solving needed more" in text


@pytest.mark.slow
def test_a_time_bomb_is_stopped_by_the_time_budget(monkeypatch: pytest.MonkeyPatch, runner: CliRunner) -> None:
    """10^9 combinations that make no atom: little memory, a lot of time; a 1-second budget stops it."""
    monkeypatch.setenv("BELIEFLOC_MAX_KB_SECONDS", "1")
    monkeypatch.setenv("BELIEFLOC_MAX_KB_BYTES", "500000000")
    with pytest.raises(LimitError, match=r"took more than the limit of 1 seconds.*BELIEFLOC_MAX_KB_SECONDS=N"):
        KnowledgeBase(load_domain(PRINTER), [FUZZ_KB / "bomb_time.lp"])
    text = refused(runner.invoke(app, ["kb", "check", str(HOME), "--kb", str(FUZZ_KB / "bomb_time.lp")]))
    assert "home.yaml (with " in text and "raise it with the environment variable BELIEFLOC_MAX_KB_SECONDS=N" in text


def _children(pid: int) -> list[int]:
    try:
        text = Path(f"/proc/{pid}/task/{pid}/children").read_text()
    except OSError:
        return []
    return [int(part) for part in text.split()]


@pytest.mark.skipif(not Path("/proc/self/task").is_dir(), reason="needs Linux's /proc to see the child process")
def test_ctrl_c_stops_a_grounding_at_once() -> None:
    """Ctrl-C (SIGINT to the process group) during a grounding that would take gigabytes: the
    command exits with 130, no traceback, and no process of it is left."""
    env = {**os.environ, "BELIEFLOC_MAX_KB_BYTES": "1500000000", "BELIEFLOC_MAX_KB_SECONDS": "120"}
    command = [sys.executable, "-m", "beliefloc", "kb", "check", str(HOME), "--kb", str(FUZZ_KB / "bomb_memory.lp")]
    proc = subprocess.Popen(command, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True)
    try:
        for _ in range(600):  # wait for the child that grounds (imports come first)
            if _children(proc.pid) or proc.poll() is not None:
                break
            time.sleep(0.05)
        assert _children(proc.pid), "the grounding never started in a child process"
        os.killpg(proc.pid, signal.SIGINT)
        _, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    assert proc.returncode in (130, -signal.SIGINT), err.decode()
    assert b"Traceback" not in err and b"PANIC" not in err
    with pytest.raises(ProcessLookupError):
        os.killpg(proc.pid, 0)  # nothing of the group is left


def test_the_budgeted_answer_is_the_answer() -> None:
    """The first grounding runs in a child process, later ones of the same shape here: both agree."""
    domain = load_domain(PRINTER)
    program_module._PROVEN.clear()
    first = KnowledgeBase(domain)
    assert first._control is None  # answered by the budget's child process
    again = KnowledgeBase(domain)
    assert again._control is not None  # the same shape: grounded in this process
    assert first.answer().literals == again.answer().literals and first.answer().models == again.answer().models
    assert first.prior("printer") == again.prior("printer")
    assert first.observe(Observation("book1", "bedroom"))  # grounds here on demand
    assert first.answer().located()["book1"] == "bedroom"


def test_errors_in_the_budgets_child_keep_their_class_and_message(tmp_path: Path) -> None:
    inconsistent = write(tmp_path / "no.lp", "-holds(in(book1, study), 1).\n")
    program_module._PROVEN.clear()
    with pytest.raises(KnowledgeBaseError, match=r"^the knowledge base is inconsistent"):
        KnowledgeBase(load_domain(PRINTER), [inconsistent])
    odd = write(tmp_path / "odd.lp", "holds(in(X, study), 1) :- is(X, book), fragile(X).\n")
    kb = KnowledgeBase(load_domain(PRINTER), [odd])
    assert [w for w in kb.warnings if "fragile" in w] and all(str(odd) in w for w in kb.warnings if "fragile" in w)


# -- 3 and 8. a deep class hierarchy -----------------------------------------------------------------------


def chain_domain(tmp_path: Path, depth: int, *, tail: str = "", objects: str = "") -> Path:
    lines = ["name: chain", "rooms: [kitchen, study]", "classes:", "  c0:"]
    lines += [f"  c{i}: c{i - 1}" for i in range(1, depth)]
    return write(tmp_path / "chain.yaml", "\n".join([*lines, *([tail] if tail else []), objects]) + "\n")


def test_a_5000_level_class_chain_loads_and_grounds_in_little_memory(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, runner: CliRunner
) -> None:
    """The cycle check is linear, and the axioms no longer ground every (class, ancestor) pair
    (12.5 million atoms, gigabytes): a 150 MB budget is plenty."""
    path = chain_domain(tmp_path, 5000, objects="objects:\n  deep: {class: c4999, room: study}")
    monkeypatch.setenv("BELIEFLOC_MAX_KB_BYTES", "150000000")
    out = runner.invoke(app, ["kb", "check", str(path)])
    assert out.exit_code == 0, out.output
    assert "5000 classes, 1 of 1 objects located" in " ".join(out.stdout.split())
    result = KnowledgeBase(load_domain(path)).prior("c0")
    assert result.prior["study"] > result.prior["kitchen"]


def test_a_cycle_at_the_end_of_a_long_chain_is_named(tmp_path: Path) -> None:
    path = chain_domain(tmp_path, 3000, tail="  x: y\n  y: x")
    with pytest.raises(DomainError, match=r"chain\.yaml:3004:6: classes\.x: cycle in the class hierarchy: x -> y -> x"):
        load_domain(path)
    with pytest.raises(DomainError, match=r"classes\.a: cycle in the class hierarchy: a -> c -> b -> a"):
        load_domain(FUZZ_DOMAINS / "class_cycle_late.yaml")


def test_a_deep_and_wide_hierarchy_gives_a_prior_not_an_overflow() -> None:
    """2^1200 as a product of weights: the psi term is 0, not an OverflowError."""
    parents = {"c0": "root", "leaf0": "root"}
    for i in range(1, 1200):
        parents[f"c{i}"] = f"c{i - 1}"
        parents[f"leaf{i}"] = f"c{i - 1}"
    result = room_prior(["a", "b"], parents, {"a": {"c1199": 3}, "b": {"leaf0": 1}}, "leaf0")
    assert all(math.isfinite(p) for p in result.prior.values()) and result.prior["b"] > result.prior["a"]


# -- 5. paths: relative to their own file, inside its folder tree ----------------------------------------


def test_includes_are_resolved_relative_to_their_own_file(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """clingo would try the working folder first: a decoy there must not be read."""
    write(tmp_path / "includes" / "inner.lp", "is(decoy, computer).\n")
    monkeypatch.chdir(tmp_path)
    kb = KnowledgeBase(load_domain(PRINTER), [FUZZ_KB / "include_nested.lp"])
    objects = {obj for obj, _ in kb.answer().members}
    assert {"inner1", "up1"} <= objects and "decoy" not in objects


def test_an_include_of_itself_is_read_once(tmp_path: Path) -> None:
    kb = KnowledgeBase(load_domain(PRINTER), [FUZZ_KB / "include_self.lp"])
    assert ("self1", "computer") in kb.answer().members
    assert any("already included" in w for w in kb.warnings)
    assert not any("beliefloc-kb-" in w for w in kb.warnings)


def test_commented_directives_are_not_directives() -> None:
    assert directives((FUZZ_KB / "commented.lp").read_text()) == []
    KnowledgeBase(load_domain(PRINTER), [FUZZ_KB / "commented.lp"]).answer()
    found = directives('p.\n  #include "a.lp". %* x *% #include\n "b.lp".\n#includes "c".\n#script(lua)\n')
    assert [(d.kind, d.line, d.column, d.name) for d in found] == [
        ("include", 2, 3, "a.lp"),
        ("include", 2, 28, "b.lp"),
        ("script", 5, 1, ""),
    ]


@pytest.mark.parametrize(
    ("name", "where", "message"),
    [
        ("kb_outside.yaml", "4:6", r"kb\[0\]: \.\./\S*etc/passwd is outside the folder \S*domains of the domain file"),
        ("kb_absolute.yaml", "4:6", r"kb\[0\]: /etc/passwd is an absolute path; name the file relative"),
        ("kb_folder.yaml", "4:6", r"kb\[0\]: \.: is a folder, not a file"),
        ("kb_missing.yaml", "4:6", r"kb\[0\]: nowhere\.lp: no such knowledge-base file"),
        ("kb_script_outside.yaml", "4:6", r"kb\[0\]: \.\./kb/script_python\.lp is outside the folder"),
    ],
)
def test_kb_paths_of_a_domain(name: str, where: str, message: str, runner: CliRunner) -> None:
    path = FUZZ_DOMAINS / name
    with pytest.raises(DomainError, match=rf"^{path}:{where}: {message}"):
        load_domain(path)
    text = refused(runner.invoke(app, ["kb", "check", str(path)]))
    assert f"{path}:{where}: " in text
    if "outside" in message or "absolute" in message:
        assert "--allow-outside reads it anyway" in text


def test_allow_outside_reads_files_out_of_the_tree(runner: CliRunner) -> None:
    """With --allow-outside the file is read, and then checked like any other (here: its #script)."""
    path = FUZZ_DOMAINS / "kb_script_outside.yaml"
    domain = load_domain(path, allow_outside=True)
    assert domain.allow_outside
    with pytest.raises(KnowledgeBaseError, match=r"script_python\.lp:3:1: #script"):
        KnowledgeBase(domain)
    text = refused(runner.invoke(app, ["kb", "check", str(path), "--allow-outside"]))
    assert "script_python.lp:3:1: #script" in text
    with pytest.raises(KnowledgeBaseError, match=r"outside\.lp: no such knowledge-base file"):
        KnowledgeBase(load_domain(PRINTER, allow_outside=True), [FUZZ_KB / "include_parent.lp"])


def test_a_link_out_of_the_domains_folder_is_outside(tmp_path: Path) -> None:
    secret = write(tmp_path / "elsewhere" / "secret.lp", "is(secret, book).\n")
    home = tmp_path / "home"
    write(home / "ok.lp", "is(mine, book).\n")
    (home / "link.lp").symlink_to(secret)
    write(home / "d.yaml", "name: d\nrooms: [kitchen]\nclasses: {object: null, book: object}\nkb: [ok.lp, link.lp]\n")
    with pytest.raises(DomainError, match=r"d\.yaml:4:13: kb\[1\]: link\.lp is outside the folder"):
        load_domain(home / "d.yaml")
    write(home / "inc.lp", '#include "link.lp".\n')
    with pytest.raises(KnowledgeBaseError, match=r'inc\.lp:1:1: #include "link\.lp": is outside the folder'):
        KnowledgeBase(domain_from_data(small(kb=["inc.lp"]), home / "x.yaml"))
    kb = KnowledgeBase(domain_from_data(small(kb=["inc.lp"]), home / "x.yaml", allow_outside=True))
    assert ("secret", "book") in kb.answer().members


@pytest.mark.parametrize(
    "command",
    [["kb", "check"], ["kb", "answer"], ["prior"], ["search", "run"], ["search", "simulate"]],
    ids=" ".join,
)
def test_every_command_that_reads_a_domain_takes_allow_outside(command: list[str], runner: CliRunner) -> None:
    out = runner.invoke(app, [*command, "--help"])
    assert out.exit_code == 0 and "--allow-outside" in out.stdout
    text = refused(runner.invoke(app, [*command, str(FUZZ_DOMAINS / "kb_absolute.yaml")]))
    assert "kb[0]: /etc/passwd is an absolute path" in text


# -- 6. domain files: strict numbers, finite floats, internal names, the wrong kind of file --------------

DOMAIN_CASES = [
    ("bool_steps.yaml", "4:8", r"steps: should be an integer, got true \(a boolean\)"),
    ("bool_weight.yaml", "4:32", r"robot\.weight: should be a number, got true \(a boolean\)"),
    ("bool_view.yaml", "7:18", r"search\.sensor\.view: should be an integer, got true"),
    ("bool_placement.yaml", "5:28", r"search\.placement\.kitchen\[1\]: should be an integer, got false"),
    ("float_placement.yaml", "5:43", r"search\.placement\.study\[1\]: should be an integer, got 1\.5"),
    ("number_accessible.yaml", "3:25", r"rooms\.kitchen\.accessible: should be true or false, got 0"),
    ("text_accessible.yaml", "3:25", r"rooms\.kitchen\.accessible: should be true or false, got 'yes'"),
    ("nan_weight.yaml", "4:32", r"robot\.weight: should be a finite number, got nan"),
    ("inf_time_limit.yaml", "7:15", r"search\.time_limit: should be a finite number, got inf"),
    ("huge_cost.yaml", "7:19", r"search\.costs\.travel: should be less than or equal to 1000000"),
    ("internal_class_key.yaml", "5:16", r"objects\.b1\.class_: unknown key 'class_'; expected one of: class, on"),
    ("internal_default_class_key.yaml", "5:28", r"defaults\.books_in_study\.class_: unknown key 'class_'"),
    ("internal_map_search_key.yaml", "4:13", r"map_search: unknown key 'map_search'; expected one of: .*search"),
    ("duplicate_room.yaml", "2:25", r"rooms\[2\]: room 'kitchen' is listed twice"),
    ("room_not_a_name.yaml", "2:9", r"rooms\[0\]: a room is a name, got a list"),
    ("class_cycle_late.yaml", "3:28", r"classes\.a: cycle in the class hierarchy"),
]
KB_PATH_CASES = {"kb_outside.yaml", "kb_absolute.yaml", "kb_folder.yaml", "kb_missing.yaml", "kb_script_outside.yaml"}


@pytest.mark.parametrize(("name", "where", "message"), DOMAIN_CASES, ids=[c[0] for c in DOMAIN_CASES])
def test_every_hostile_domain_is_refused_with_its_line(name: str, where: str, message: str, runner: CliRunner) -> None:
    path = FUZZ_DOMAINS / name
    with pytest.raises(DomainError, match=rf"^{path}:{where}: {message}"):
        load_domain(path)
    assert f"{path}:{where}: " in refused(runner.invoke(app, ["prior", str(path)]))


def test_every_domain_corpus_file_has_a_case() -> None:
    named = {c[0] for c in DOMAIN_CASES} | KB_PATH_CASES
    assert {p.name for p in FUZZ_DOMAINS.glob("*.yaml")} == named


def test_every_number_refuses_booleans_and_every_float_nan() -> None:
    """Through the plain-data door too, for every number of every section."""
    search: dict[str, Any] = {
        "placement": {"kitchen": [0, 0], "study": [0, 5]},
        "robot_start": {"room": "kitchen", "cell": [0, 0]},
    }
    numbers: list[tuple[dict[str, Any], str]] = [
        ({"steps": True}, "steps"),
        ({"robot": {"weight": True}}, "robot.weight"),
        ({"search": {**search, "time_limit": True}}, "search.time_limit"),
        ({"search": {**search, "tau_found": False}}, "search.tau_found"),
        ({"search": {**search, "tau_absent": math.nan}}, "search.tau_absent"),
        ({"search": {**search, "costs": {"analysis": True}}}, "search.costs.analysis"),
        ({"search": {**search, "costs": {"travel": math.inf}}}, "search.costs.travel"),
        ({"search": {**search, "existence": {"alpha": True}}}, "search.existence.alpha"),
        ({"search": {**search, "existence": {"beta": math.inf}}}, "search.existence.beta"),
        ({"search": {**search, "sensor": {"true_positive": True}}}, "search.sensor.true_positive"),
        ({"search": {**search, "sensor": {"false_positive": math.nan}}}, "search.sensor.false_positive"),
        ({"search": {**search, "room_size": [True, 5]}}, "search.room_size"),
        ({"search": {**search, "robot_start": {"room": "kitchen", "cell": [0, True]}}}, "search.robot_start.cell"),
    ]
    for extra, field in numbers:
        with pytest.raises(DomainError, match=rf"^{field}"):
            domain_from_data(small(**extra))
    # a whole number is a number: ints are floats
    domain = domain_from_data(small(robot={"weight": 1}, search={**search, "time_limit": 50}))
    assert domain.robot is not None and domain.robot.weight == 1.0


def test_every_field_written_by_another_name_is_refused_by_its_python_name() -> None:
    """A new alias must be refused where it is written: the list here is the one the domain checks."""
    models: list[type[_Strict]] = [*_Strict.__subclasses__()]
    models += [sub for model in list(models) for sub in model.__subclasses__()]
    aliased = {(model.__name__, name) for model in models for name in aliased_fields(model)}
    assert aliased == {("ObjectInstance", "class_"), ("Default", "class_"), ("Domain", "map_search")}
    assert aliased_fields(ObjectInstance) == aliased_fields(Default) == ["class_"]
    with pytest.raises(DomainError, match=r"^objects\.b\.class_: unknown key 'class_'"):
        domain_from_data(small(objects={"b": {"class_": "book"}}))


def test_a_map_given_as_a_domain_says_so(runner: CliRunner) -> None:
    kitchen = ROOT / "maps" / "kitchen.yaml"
    with pytest.raises(DomainError, match=rf"^{kitchen} is a map, not a knowledge-base domain"):
        load_domain(kitchen)
    text = refused(runner.invoke(app, ["prior", "maps/kitchen.yaml"]))
    assert text.startswith("error: maps/kitchen.yaml is a map, not a knowledge-base domain")


# -- 7. numbers on the command line --------------------------------------------------------------------


@pytest.mark.parametrize(
    ("args", "option"),
    [
        (["prior", str(HOME), "--target", "printer", "--floor", "nan"], "--floor"),
        (["prior", str(HOME), "--target", "printer", "--floor", "inf"], "--floor"),
        (["prior", str(HOME), "--target", "printer", "--floor", "0.5"], "--floor 0.5"),
        (["prior", str(ROOT / "domains" / "apartment.yaml"), "--robot", "--weight", "nan"], "--weight"),
        (["prior", str(ROOT / "domains" / "apartment.yaml"), "--robot", "--weight", "inf"], "--weight"),
        (["search", "run", str(HOME), "--target", "printer", "--seed", "-1"], "--seed"),
        (["search", "run", str(HOME), "--target", "printer", "--time-limit", "nan"], "--time-limit"),
        (["search", "run", str(HOME), "--target", "printer", "--time-limit", "inf"], "--time-limit"),
        (["search", "run", str(HOME), "--target", "printer", "--commit-threshold", "nan"], "--commit-threshold"),
        (["search", "run", str(HOME), "--target", "printer", "--trust-weight", "nan"], "--trust-weight"),
        (["search", "run", str(HOME), "--target", "printer", "--trust-r", "inf"], "--trust-r"),
        (["search", "simulate", str(HOME), "-n", "1", "--knowledge", "nan"], "--knowledge"),
        (["search", "simulate", str(HOME), "-n", "1", "--absent-fraction", "inf"], "--absent-fraction"),
        (["search", "simulate", str(HOME), "-n", "1", "--time-limit", "-inf"], "--time-limit"),
        (["search", "simulate", str(HOME), "-n", "1", "--seed", "-1"], "--seed"),
        (["kb", "answer", str(HOME), "--seen", "Book1=kitchen"], "--seen 'Book1=kitchen'"),
    ],
    ids=lambda v: " ".join(v[2:]) if isinstance(v, list) else v,
)
def test_cli_numbers_are_finite_and_named(args: list[str], option: str, runner: CliRunner) -> None:
    text = refused(runner.invoke(app, args))
    assert option in text


def test_library_numbers_are_finite() -> None:
    with pytest.raises(ValueError, match="the floor must be above 0"):
        room_prior(["a", "b"], {}, {}, "x", floor=math.nan)
    with pytest.raises(InvalidValueError, match="positive and finite"):
        check_time_limit(math.inf)
    with pytest.raises(InvalidValueError, match="the floor must be above 0"):
        KnowledgeBase(load_domain(PRINTER)).prior("printer", floor=math.nan)


# -- 8. names and other checks -----------------------------------------------------------------------------


@pytest.mark.parametrize("text", ["Book1=kitchen", "book1=Kitchen", "x:Book=kitchen", "a b=kitchen", "é=kitchen"])
def test_observed_names_are_names_of_the_knowledge_base(text: str) -> None:
    with pytest.raises(InvalidValueError, match="is not a name of the knowledge base"):
        Observation.parse(text)


@pytest.mark.parametrize(
    ("name", "why"), [("study", "is a room"), ("printer", "is a class"), ("robot", "is the robot itself")]
)
def test_a_new_object_cannot_take_the_name_of_a_room_a_class_or_the_robot(name: str, why: str) -> None:
    kb = KnowledgeBase(load_domain(PRINTER))
    with pytest.raises(KnowledgeBaseError, match=f"the new object '{name}' {why}"):
        kb.observe(Observation(name, "kitchen", "book"))
    assert kb.observations == ()


def test_room_overlap_check_agrees_with_every_pair() -> None:
    """The sweep finds an overlap exactly when some pair overlaps, and names one that does."""
    rng = random.Random(7)
    for _ in range(300):
        boxes = {
            f"r{i}": (rng.randrange(12), rng.randrange(12), rng.randrange(1, 4), rng.randrange(1, 4))
            for i in range(rng.randrange(1, 7))
        }

        def overlap(a: str, b: str, boxes: dict[str, tuple[int, int, int, int]] = boxes) -> bool:
            r1, c1, h1, w1 = boxes[a]
            r2, c2, h2, w2 = boxes[b]
            return r1 < r2 + h2 and r2 < r1 + h1 and c1 < c2 + w2 and c2 < c1 + w1

        names = list(boxes)
        expected = any(overlap(a, b) for i, a in enumerate(names) for b in names[:i])
        found = _overlapping(boxes)
        assert (found is not None) == expected, boxes
        if found is not None:
            later, earlier = found
            assert overlap(later, earlier) and names.index(later) > names.index(earlier)


def test_many_rooms_on_a_plane_are_checked(tmp_path: Path) -> None:
    """3,000 rooms side by side (each pair compared would be 4.5 million tests), then one overlap."""
    rooms = [f"r{i}" for i in range(3000)]
    placement = {room: [0, 5 * i] for i, room in enumerate(rooms)}
    start = {"room": "r0", "cell": [0, 0]}
    data = small(rooms=rooms, search={"placement": placement, "robot_start": start})
    assert len(domain_from_data(data).rooms) == 3000
    placement["r2999"] = [4, 3]
    with pytest.raises(DomainError, match=r"search\.placement\.r2999: room 'r2999' overlaps room 'r[01]'"):
        domain_from_data(small(rooms=rooms, search={"placement": placement, "robot_start": start}))


def test_default_class_models_are_strict() -> None:
    """Code still builds objects and defaults by their Python names (populate_by_name)."""
    assert ObjectInstance(class_="book").class_ == "book"
    assert Default(class_="book", room="study").room == "study"
