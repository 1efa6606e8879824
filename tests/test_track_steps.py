"""``beliefloc track --steps FILE|-``: a logged run replayed from a step file, and the final pose."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sp
from rich.text import Text
from typer.testing import CliRunner

from beliefloc import compile_model, load_map
from beliefloc.belief import by_state_name
from beliefloc.cli.app import app
from beliefloc.errors import EXIT_BAD_INPUT, ImpossibleObservationError, InputFileError, InvalidValueError
from beliefloc.model import Action, ActionKind, Model, ObservationModel, ObservationPart, StateSpace
from beliefloc.pose import belief_pose, pose_json
from beliefloc.render import print_lines
from beliefloc.render.state_tables import print_step_summaries, step_header, summary_line, summary_lines
from beliefloc.robots.tracking import (
    StepLine,
    argument_log,
    read_step_file,
    resolve_steps,
    step_lines,
    text_log,
    track_beliefs,
    track_chunks,
)

from .conftest import MAPS

KITCHEN = str(MAPS / "kitchen.yaml")
STORY = ["look=nothing", "scan=no_wall", "rotate_ccw", "look=potted_plant", "forward", "scan=wall_0.2-0.8"]
LOG = """\
# Colledanchise Sec. VII-B, Experiment 1
look=nothing          # from the centre, facing east

scan=no_wall
rotate_ccw
   look=potted_plant
forward
scan=wall_0.2-0.8
"""


def test_step_lines_skip_blank_lines_and_comments() -> None:
    lines = step_lines(LOG, "run.log")
    assert [line.text for line in lines] == STORY
    assert lines[0] == StepLine("look=nothing", "run.log:2: 'look=nothing'")
    assert lines[2].label == "run.log:5: 'rotate_ccw'"


def test_a_file_of_comments_has_no_steps() -> None:
    with pytest.raises(InvalidValueError, match=r"^run.log: no steps, only blank lines and comments"):
        step_lines("# nothing yet\n\n", "run.log")


def test_messages_name_the_file_and_line() -> None:
    model = compile_model(load_map(MAPS / "window-2x2-perfect.yaml"))
    lines = step_lines("look=window_seen\nright\n\nlook=nothing\n", "run.log")
    with pytest.raises(InvalidValueError, match=r"^run.log:2: 'lookk': unknown action 'lookk'"):
        resolve_steps(model, step_lines("right\nlookk\n", "run.log"))
    steps = resolve_steps(model, lines)
    with pytest.raises(
        ImpossibleObservationError, match=r"^run.log:4: 'look=nothing': observation 'nothing' after 'look' has pro"
    ):
        list(track_beliefs(model, np.full(4, 0.25), steps))


def test_read_step_file_guards_the_file(tmp_path: Path) -> None:
    with pytest.raises(InputFileError, match=r"missing.log: no such file"):
        read_step_file(tmp_path / "missing.log")
    with pytest.raises(InputFileError, match=r": is a folder, not a file"):
        read_step_file(tmp_path)
    (tmp_path / "bad.log").write_bytes(b"look=nothing\n\xff\n")
    with pytest.raises(InputFileError, match=r"bad.log:2: not UTF-8 text"):
        read_step_file(tmp_path / "bad.log")


def _json(runner: CliRunner, *args: str, stdin: str | None = None) -> dict[str, object]:
    result = runner.invoke(app, ["track", KITCHEN, "--json", *args], input=stdin)
    assert result.exit_code == 0, result.output
    data: dict[str, object] = json.loads(result.stdout)
    return data


def test_a_step_file_and_stdin_replay_the_arguments(runner: CliRunner, tmp_path: Path) -> None:
    log = tmp_path / "run.log"
    log.write_text(LOG)
    from_arguments = _json(runner, *STORY)
    assert _json(runner, "--steps", str(log)) == from_arguments
    assert _json(runner, "--steps", "-", stdin=LOG) == from_arguments


def test_track_json_gives_the_pose_of_the_final_belief(runner: CliRunner) -> None:
    data = _json(runner, *STORY)
    model = compile_model(load_map(KITCHEN))
    belief = [data["belief"][name] for name in model.states.names]  # type: ignore[index]
    expected = belief_pose(model, np.array(belief)).as_json()
    pose = data["pose"]
    assert isinstance(pose, dict) and set(pose) == set(expected)
    assert [pose[k] for k in ("x", "y", "yaw")] == pytest.approx([expected[k] for k in ("x", "y", "yaw")])
    assert pose["covariance"] == pytest.approx(expected["covariance"])
    assert (data["pose"]["x"], data["pose"]["y"]) == pytest.approx((1.8, 3.0))  # type: ignore[index]  # "0,1,0"


@pytest.mark.parametrize(
    ("args", "stdin", "message"),
    [
        (["--steps", "{log}", "look=nothing"], None, "--steps {log}: give the steps either as STEP... arguments or"),
        ([], None, "no steps: give them as STEP... arguments or one per line with --steps FILE|-"),
        (["--steps", "-"], "look=nothing\nlookk=x\n", "<stdin>:2: 'lookk=x': unknown action 'lookk'"),
        (["--steps", "-"], "# only a comment\n", "<stdin>: no steps, only blank lines and comments"),
        (["--steps", "{log}"], None, "run.log:8: 'scan=wal': unknown observation 'wal'"),
        (["--steps", "{missing}"], None, "missing.log: no such file"),
    ],
)
def test_bad_steps_exit_2_naming_file_and_line(
    runner: CliRunner, tmp_path: Path, args: list[str], stdin: str | None, message: str
) -> None:
    log = tmp_path / "run.log"
    log.write_text(LOG.replace("scan=wall_0.2-0.8", "scan=wal"))
    names = {"log": str(log), "missing": str(tmp_path / "missing.log")}
    result = runner.invoke(app, ["track", KITCHEN, *(a.format(**names) for a in args)], input=stdin)
    assert result.exit_code == EXIT_BAD_INPUT
    assert isinstance(result.exception, SystemExit)
    stderr = " ".join(result.stderr.split())
    assert stderr.startswith("error: ") and message.format(**names) in stderr
    assert result.stdout == ""


def test_a_model_without_grid_has_a_null_pose(runner: CliRunner, monkeypatch: pytest.MonkeyPatch) -> None:
    """An imported .pomdp has no grid, so its states have no pose: ``"pose": null``, as ``show`` says."""
    from beliefloc.files import model_sources

    from .test_render import rooms_model

    monkeypatch.setattr(model_sources, "open_model", lambda path, **_: rooms_model())
    result = runner.invoke(app, ["track", "rooms.pomdp", "stay", "--json"])
    assert result.exit_code == 0, result.output
    assert json.loads(result.stdout)["pose"] is None


# --- a long log: held compactly, filtered a chunk at a time, printed without rich per line ----------


def _random_model(seed: int, n: int = 12) -> Model:
    """A model no bundled map is: up to six successors a state (the bundled maps have two, so the
    order of the sums is tested), readings of probability 0 (zeros in beliefs, impossible
    observations), and state names that need escaping in JSON and in a terminal."""
    rng = np.random.default_rng(seed)
    actions = []
    for a in range(3):
        rows, cols, data = [], [], []
        for i in range(n):
            to = rng.choice(n, size=int(rng.integers(1, 7)), replace=False)
            weights = rng.random(len(to)) ** 3
            rows += [i] * len(to)
            cols += to.tolist()
            data += (weights / weights.sum()).tolist()
        transition = sp.csr_matrix((data, (rows, cols)), shape=(n, n))
        actions.append(Action(f"move{a}", ActionKind.ACTUATION, 1.0, transition, ObservationModel(n)))
    confusion = rng.random((3, 3)) * (rng.random((3, 3)) > 0.3)
    confusion[np.arange(3), np.arange(3)] += 1.0
    confusion /= confusion.sum(axis=1, keepdims=True)
    part = ObservationPart("eye", ("", "red", "blue"), rng.integers(0, 3, n), confusion)
    actions.append(Action("look", ActionKind.PERCEPTION, 1.0, None, ObservationModel(n, (part,))))
    names = [f"s{i}" for i in range(n - 4)] + ["a%s", "ü ß", "\x1b[2Jbad", '"q"']
    return Model("random", StateSpace(n, names=names), tuple(actions))


def _walk(model: Model, length: int, seed: int) -> list[str]:
    """Steps a robot in ``model`` could log (each observation possible: drawn from the true state)."""
    rng = np.random.default_rng(seed)
    state = int(rng.integers(model.n_states))
    steps = []
    for _ in range(length):
        action = model.actions[int(rng.integers(len(model.actions)))]
        if action.transition is not None:
            row = action.transition.toarray()[state]
            state = int(rng.choice(model.n_states, p=row / row.sum()))
            steps.append(action.name if rng.random() < 0.5 else f"{action.name}=none")
        else:
            likelihood = action.observation.likelihood_matrix(np.array([state]))[0]
            o = int(rng.choice(len(likelihood), p=likelihood / likelihood.sum()))
            steps.append(f"{action.name}={action.observation.name(o)}")
    return steps


MODELS = [("kitchen", None), ("window-2x2-perfect", None), ("random", 1), ("random", 2)]


def _model(name: str, seed: int | None) -> Model:
    return _random_model(seed) if seed is not None else compile_model(load_map(MAPS / f"{name}.yaml"))


@pytest.mark.parametrize(("name", "seed"), MODELS)
def test_track_chunks_gives_track_beliefs_bit_for_bit(name: str, seed: int | None) -> None:
    model = _model(name, seed)
    texts = _walk(model, 700, seed=5)
    start = np.full(model.n_states, 1.0 / model.n_states)
    slow = list(track_beliefs(model, start, resolve_steps(model, texts)))
    log = argument_log(model, texts)
    chunks = list(track_chunks(model, start, log, size=64))
    assert [c.start for c in chunks] == list(range(0, 700, 64))
    beliefs = np.concatenate([c.beliefs for c in chunks])
    probabilities = np.concatenate([c.probabilities for c in chunks])
    codes = np.concatenate([c.codes for c in chunks])
    assert np.array_equal(beliefs, np.array([t.belief for t in slow]))  # the same bits, not close ones
    assert [None if log.steps[c].index is None else p for c, p in zip(codes, probabilities, strict=True)] == [
        t.probability for t in slow
    ]
    assert [log.steps[c].text for c in codes] == texts
    if name != "kitchen":  # beliefs with zeros: the filter's exact zeros, not tiny numbers
        assert (beliefs == 0.0).any()


def test_track_chunks_stops_where_track_beliefs_does() -> None:
    model = compile_model(load_map(MAPS / "window-2x2-perfect.yaml"))
    log = text_log(model, "look=window_seen\nright\n\nlook=nothing\nright\n", "run.log")
    start = np.full(4, 0.25)
    with pytest.raises(ImpossibleObservationError) as slow:
        list(
            track_beliefs(
                model, start, resolve_steps(model, step_lines("look=window_seen\nright\n\nlook=nothing\n", "run.log"))
            )
        )
    chunks = []
    with pytest.raises(ImpossibleObservationError) as fast:
        chunks.extend(track_chunks(model, start, log))
    assert str(fast.value) == str(slow.value) and str(fast.value).startswith("run.log:4: 'look=nothing': ")
    assert [len(c.codes) for c in chunks] == [2]  # the steps before the impossible one


def test_a_step_log_is_what_step_lines_and_resolve_steps_read() -> None:
    model = compile_model(load_map(KITCHEN))
    text = LOG + "look=nothing  # again\n\nforward\n" * 3
    log = text_log(model, text, "run.log")
    resolved = resolve_steps(model, step_lines(text, "run.log"))
    assert len(log) == len(resolved) and len(log.steps) == len(STORY)
    assert [log.step(i) for i in range(len(log))] == resolved
    assert argument_log(model, STORY).step(2) == resolve_steps(model, STORY)[2]
    for bad, message in [
        ("forward\nlookk\n", r"^run.log:2: 'lookk': unknown action 'lookk'"),
        ("\n# nothing\n", r"^run.log: no steps, only blank lines and comments"),
        ("forward\nlook   # a perception needs its reading\n", r"^run.log:2: 'look': 'look' is a perception action"),
    ]:
        with pytest.raises(InvalidValueError, match=message):
            text_log(model, bad, "run.log")


def test_a_log_of_distinct_lines_is_read_alike() -> None:
    """Every line differs by its comment: each is looked at, and the steps are still held once."""
    model = compile_model(load_map(KITCHEN))
    text = "".join(f"{step}  # t={i}\n" for i, step in enumerate(STORY * 3))
    log = text_log(model, text, "run.log")
    assert [log.step(i).text for i in range(len(log))] == STORY * 3 and len(log.steps) == len(STORY)
    assert log.step(17).label == "run.log:18: 'scan=wall_0.2-0.8'"
    with pytest.raises(InvalidValueError, match=r"^run.log:20: 'scan=wal': unknown observation 'wal'"):
        text_log(model, text + "forward # t=18\nscan=wal  # t=19\n", "run.log")


@pytest.mark.parametrize(("name", "seed"), MODELS)
def test_summary_lines_are_summary_line(name: str, seed: int | None) -> None:
    model = _model(name, seed)
    start = np.full(model.n_states, 1.0 / model.n_states)
    beliefs = np.concatenate([c.beliefs for c in track_chunks(model, start, argument_log(model, _walk(model, 300, 3)))])
    rng = np.random.default_rng(0)
    ties = np.zeros((3, model.n_states))
    ties[0, :2] = 0.5  # a tie
    ties[1, -1] = 1.0  # a point mass: entropy -0
    ties[2] = rng.random(model.n_states) ** 20
    beliefs = np.concatenate([beliefs, ties])
    assert summary_lines(model, beliefs) == [summary_line(model, b).plain for b in beliefs]


@pytest.mark.parametrize("width", [30, 60, 120])
@pytest.mark.parametrize("color", [False, True])
def test_print_step_summaries_prints_what_print_lines_prints(width: int, color: bool) -> None:
    """Long steps and state names are wrapped as rich wraps them; control codes are stripped alike."""
    import io

    from rich.console import Console

    model = _random_model(3)
    texts = _walk(model, 40, 4)
    texts[7] = "look=red  " if texts[7].startswith("look") else texts[7]
    log = argument_log(model, texts)
    chunk = next(track_chunks(model, np.full(model.n_states, 1 / model.n_states), log))
    options = {
        "width": width,
        "highlight": False,
        "force_terminal": color,
        "color_system": "standard" if color else None,
    }
    fast, slow = io.StringIO(), io.StringIO()
    print_step_summaries(
        Console(file=fast, **options), model, log.steps, 5, chunk.codes, chunk.probabilities, chunk.beliefs
    )
    lines = []
    for i, code in enumerate(chunk.codes.tolist()):
        step = log.steps[code]
        p = None if step.index is None else float(chunk.probabilities[i])
        lines += [Text()] * (5 + i > 1) + [step_header(5 + i, step.text, step.action.name, step.observation, p)]
        lines.append(summary_line(model, chunk.beliefs[i]))
    print_lines(Console(file=slow, **options), lines)
    assert fast.getvalue() == slow.getvalue()
    assert "\x1b[2J" not in fast.getvalue()


def test_float_reprs_are_json_dumps(monkeypatch: pytest.MonkeyPatch) -> None:
    from beliefloc.cli import track_steps

    rng = np.random.default_rng(0)
    values = np.concatenate(
        [
            rng.random(20_000) ** rng.uniform(1, 80, 20_000),  # every exponent a belief has
            [0.0, 1.0, 1e-4, np.nextafter(1e-4, 0), 1e-9, np.nextafter(1e-9, 0), 5e-324, 2.2250738585072014e-308],
            [1e16, 1e-5, 1.5e-10, 0.1, 1 / 3, 123.0, 1e22],
        ]
    )
    reference = json.dumps(values.tolist())[1:-1].split(", ")
    assert track_steps._ujson_reprs(values.tolist()) == reference  # the fast path itself, unchecked
    assert track_steps.float_reprs(values.reshape(-1, 5)) == reference
    # an encoder that writes otherwise is noticed by the sample, and repr writes every value
    monkeypatch.setattr(track_steps, "_ujson_reprs", lambda flat: [f"{v:.3g}" for v in flat])
    assert track_steps.float_reprs(values) == reference


def _reference_json(model: Model, texts: list[str]) -> str:
    """``track --json`` as the filter's steps and print_json's json.dumps would write it."""
    start = np.full(model.n_states, 1.0 / model.n_states)
    tracked = list(track_beliefs(model, start, resolve_steps(model, texts)))
    document = {
        "steps": [t.as_json(model) for t in tracked],
        "belief": by_state_name(model, tracked[-1].belief),
        "pose": pose_json(model, tracked[-1].belief),
    }
    return json.dumps(document, indent=2, allow_nan=False) + "\n"


@pytest.mark.parametrize(("name", "seed"), MODELS)
def test_track_json_of_a_log_is_print_json_of_its_steps(
    runner: CliRunner, monkeypatch: pytest.MonkeyPatch, tmp_path: Path, name: str, seed: int | None
) -> None:
    from beliefloc.files import model_sources

    model = _model(name, seed)
    texts = _walk(model, 300, 6)
    if seed is not None:
        monkeypatch.setattr(model_sources, "open_model", lambda path, **_: model)
    log = tmp_path / "run.log"
    log.write_text("\n".join(texts) + "\n", encoding="utf-8")
    source = str(MAPS / f"{name}.yaml") if seed is None else "random.pomdp"  # the latter: the model patched in
    result = runner.invoke(app, ["track", source, "--steps", str(log), "--json"])
    assert result.exit_code == 0, result.output
    assert result.stdout == _reference_json(model, texts)


def test_track_quiet_of_a_log_prints_each_step_as_before(runner: CliRunner, tmp_path: Path) -> None:
    """Every step but the last: its header and summary, as rich printed them one by one."""
    import io

    from rich.console import Console

    model = compile_model(load_map(KITCHEN))
    texts = _walk(model, 1500, 7)
    log = tmp_path / "run.log"
    log.write_text("\n".join(texts) + "\n", encoding="utf-8")
    result = runner.invoke(app, ["track", KITCHEN, "--steps", str(log), "-q"])
    assert result.exit_code == 0, result.output
    expected = io.StringIO()
    console = Console(file=expected, width=120, highlight=False, soft_wrap=False)
    tracked = list(track_beliefs(model, np.full(36, 1 / 36), resolve_steps(model, texts)))
    for t in tracked[:-1]:
        if t.number > 1:
            console.print()
        console.print(step_header(t.number, t.step.text, t.step.action.name, t.step.observation, t.probability))
        console.print(summary_line(model, t.belief))
    last = tracked[-1]
    assert result.stdout.startswith(expected.getvalue() + f"\nstep {last.number}: {last.step.text}   ")
    default = runner.invoke(app, ["track", KITCHEN, "--steps", str(log)])  # more than 1,000 steps: as -q
    assert default.exit_code == 0 and default.stdout == result.stdout
    assert "1,500 steps (more than 1,000)" in " ".join(default.stderr.split())


def test_an_impossible_step_in_a_long_log_exits_2(runner: CliRunner, tmp_path: Path) -> None:
    """The steps before it are printed (-q), no half document (--json), one paragraph on stderr."""
    log = tmp_path / "run.log"
    log.write_text("look=window_seen\nright\n" * 3000 + "look=nothing\nright\n", encoding="utf-8")
    perfect = str(MAPS / "window-2x2-perfect.yaml")
    for options in (["-q"], ["--json"]):
        result = runner.invoke(app, ["track", perfect, "--steps", str(log), *options])
        assert result.exit_code == EXIT_BAD_INPUT and isinstance(result.exception, SystemExit)
        stderr = " ".join(result.stderr.split())
        assert stderr.startswith(f"error: {log}:6001: 'look=nothing': observation 'nothing' after 'look' has pro")
        assert "Traceback" not in result.stderr
        if options == ["--json"]:
            assert result.stdout == ""
        else:
            assert result.stdout.count("most likely") == 6000
            last = result.stdout.rsplit("\n\n", 1)[1]  # step 6000, the last before the impossible one, in full
            assert last.startswith("step 6000: right   nothing observed: prediction only\nmost likely 1,1  p = 1 ")
            assert last.endswith(" nats\n")
