"""``simulate --record``: an episode animated as a GIF or a folder of numbered PNG frames."""

from __future__ import annotations

import io
import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from typer.testing import CliRunner

from beliefloc.cli.app import app
from beliefloc.errors import OutputError
from tests.conftest import DATA, MAPS

pytest.importorskip("matplotlib")
Image = pytest.importorskip("PIL.Image")

KITCHEN = MAPS / "kitchen.yaml"
SEED = ["--seed", "1", "--json", "--no-timings"]


def _simulate(*args: str) -> Any:
    return CliRunner().invoke(app, ["simulate", str(KITCHEN), *args])


def _episodes(*args: str) -> list[dict[str, Any]]:
    result = _simulate(*args, *SEED)
    assert result.exit_code == 0, result.output
    return list(json.loads(result.stdout)["episodes"])


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> Iterator[dict[str, Any]]:
    """Three kitchen episodes (seed 1: 4, 5 and 3 steps) recorded once: episode 1 as a GIF and as a
    folder, episode 2 as a GIF, and the run's --json."""
    folder = tmp_path_factory.mktemp("record")
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("COLUMNS", "120")
        runs = {
            "gif": _simulate("-n", "3", "--record", str(folder / "first.gif"), *SEED),
            "dir": _simulate("-n", "3", "--record", str(folder / "frames"), *SEED),
            "second": _simulate("-n", "3", "--record", str(folder / "second.gif"), "--record-episode", "2", *SEED),
        }
    for result in runs.values():
        assert result.exit_code == 0, result.output
    yield {"folder": folder, "runs": runs, "episodes": json.loads(runs["gif"].stdout)["episodes"]}


def _gif_frames(path: Path) -> list[Any]:
    image = Image.open(path)
    frames = []
    for k in range(image.n_frames):
        image.seek(k)
        frames.append(image.convert("RGB"))
    return frames


def test_a_gif_has_a_frame_per_step_and_the_start(recorded: dict[str, Any]):
    steps = recorded["episodes"][0]["steps"]
    frames = _gif_frames(recorded["folder"] / "first.gif")
    assert len(frames) == steps + 1
    assert len({frame.size for frame in frames}) == 1
    assert len({frame.tobytes() for frame in frames}) == len(frames)  # every step changes the picture


def test_a_folder_holds_numbered_png_frames(recorded: dict[str, Any]):
    steps = recorded["episodes"][0]["steps"]
    folder = recorded["folder"] / "frames"
    names = sorted(p.name for p in folder.iterdir())
    assert names == [f"frame-{k:03d}.png" for k in range(steps + 1)]
    sizes = set()
    for name in names:
        with Image.open(folder / name) as image:
            assert image.format == "PNG"
            sizes.add(image.size)
    assert len(sizes) == 1
    assert not [p for p in folder.parent.iterdir() if p.name.startswith(".")]  # no temporary folder left


def test_the_gif_and_the_folder_show_the_same_frames(recorded: dict[str, Any]):
    folder = recorded["folder"] / "frames"
    gif = _gif_frames(recorded["folder"] / "first.gif")
    with Image.open(folder / "frame-000.png") as png:
        assert png.size == gif[0].size


def test_record_episode_picks_the_episode_as_the_output_numbers_them(recorded: dict[str, Any]):
    first, second = recorded["episodes"][0]["steps"], recorded["episodes"][1]["steps"]
    assert first != second  # the seed tells them apart
    assert len(_gif_frames(recorded["folder"] / "second.gif")) == second + 1
    assert "recorded bestfirst, episode 2 in" in recorded["runs"]["second"].stderr


def test_json_stays_clean_and_the_recording_is_reported_on_stderr(recorded: dict[str, Any]):
    result = recorded["runs"]["gif"]
    json.loads(result.stdout)
    steps = recorded["episodes"][0]["steps"]
    assert f"recorded bestfirst, episode 1 in {steps + 1} frames" in result.stderr


def test_the_same_seed_writes_the_same_gif(tmp_path: Path, runner: CliRunner):
    for name in ("a.gif", "b.gif"):
        args = ["simulate", str(KITCHEN), "--record", str(tmp_path / name), "--record-frames", "1", "--seed", "4"]
        assert runner.invoke(app, args).exit_code == 0
    assert (tmp_path / "a.gif").read_bytes() == (tmp_path / "b.gif").read_bytes()


def test_recording_again_replaces_an_earlier_recording_whole_and_a_limit_cuts(tmp_path: Path, runner: CliRunner):
    (episode,) = _episodes()
    steps = episode["steps"]
    assert steps > 2
    frames = tmp_path / "frames"
    messages = []
    for limit in ("2", "1"):
        args = ["simulate", str(KITCHEN), "--record", str(frames), "--record-frames", limit, *SEED[:2]]
        result = runner.invoke(app, args)
        assert result.exit_code == 0, result.output
        messages.append(" ".join(result.stdout.split()))
    assert f"in 2 frames: the start and the last 1 of {steps} steps → {frames}" in messages[0]
    assert sorted(p.name for p in frames.iterdir()) == ["frame-000.png"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["frames"]


def test_record_goes_with_show(tmp_path: Path, runner: CliRunner):
    args = ["simulate", str(KITCHEN), "--show", "--record", str(tmp_path / "a.gif"), "--record-frames", "1"]
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    assert "bestfirst, episode 1, step 1:" in result.stdout
    assert (tmp_path / "a.gif").is_file()


def test_an_episode_that_starts_localized_is_one_frame(tmp_path: Path, runner: CliRunner):
    belief = tmp_path / "here.yaml"
    belief.write_text('"1,1,1": 1.0\n')
    gif = tmp_path / "one.gif"
    args = ["simulate", str(KITCHEN), "--belief", str(belief), "--start", "1,1,1", "--record", str(gif)]
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    assert "recorded bestfirst, episode 1 in 1 frame →" in result.stdout
    assert len(_gif_frames(gif)) == 1


@pytest.fixture
def workdir(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A folder to write into, holding a file, a folder of other files and a copy of the kitchen map."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "afile").write_text("not frames\n")
    (tmp_path / "notes").mkdir()
    (tmp_path / "notes" / "todo.txt").write_text("keep me\n")
    (tmp_path / "folder.gif").mkdir()
    (tmp_path / "kitchen.yaml").write_bytes(KITCHEN.read_bytes())
    return tmp_path


UNKNOWN = "unknown kind of file; expected FILE.gif, or a folder DIR for PNG frames"
BAD_RECORDS = [
    (["--record", "episode.mp4"], f"--record episode.mp4: {UNKNOWN}"),
    (["--record", "frames.png"], f"--record frames.png: {UNKNOWN}"),
    (["--record", "missing/episode.gif"], "--record missing/episode.gif: the folder missing does not exist"),
    (["--record", "missing/frames"], "--record missing/frames: the folder missing does not exist"),
    (["--record", "afile"], "--record afile: is a file; name a folder for the frames, or FILE.gif"),
    (["--record", "folder.gif"], "--record folder.gif: is a folder; name a file in it"),
    (["--record", "notes"], "--record notes: the folder holds other files than frames; name a new folder"),
    (["--record", "kitchen.yaml"], "--record kitchen.yaml: is an input of the command; name another file"),
    (["--record", "a.gif", "--record-frames", "0"], "--record-frames 0: must be a positive integer"),
    (["--record", "a.gif", "--record-frames", "-5"], "--record-frames -5: must be a positive integer"),
    (["--record", "a.gif", "--record-frames", "many"], "--record-frames many: must be a positive integer"),
    (["--record", "a.gif", "--record-episode", "0"], "--record-episode 0: must be a positive integer"),
    (["--record", "a.gif", "--record-episode", "3"], "--record-episode 3: the run has 2 episodes (--episodes)"),
    (["--record-episode", "1"], "--record-episode 1: needs --record FILE.gif|DIR"),
    (["--record-frames", "10"], "--record-frames 10: needs --record FILE.gif|DIR"),
]


@pytest.mark.parametrize(("args", "message"), BAD_RECORDS)
def test_bad_record_options_exit_2_with_one_line_and_write_nothing(
    workdir: Path, runner: CliRunner, args: list[str], message: str
):
    before = sorted(str(p.relative_to(workdir)) for p in workdir.rglob("*"))
    result = runner.invoke(app, ["simulate", "kitchen.yaml", "-n", "2", *args])
    assert result.exit_code == 2
    assert result.stderr.strip() == f"error: {message}", result.stderr
    assert "episode" not in result.stdout  # checked before any simulation
    assert sorted(str(p.relative_to(workdir)) for p in workdir.rglob("*")) == before


def test_a_model_without_a_grid_cannot_be_recorded(tmp_path: Path, runner: CliRunner):
    result = runner.invoke(app, ["simulate", str(DATA / "pomdp" / "tiger.pomdp"), "--record", str(tmp_path / "a.gif")])
    assert result.exit_code == 2
    assert "has no grid to draw an episode on" in result.stderr
    assert list(tmp_path.iterdir()) == []


# --- the library: recorder, titles, frames, writing -------------------------------------------------


@pytest.fixture(scope="module")
def traced() -> dict[str, Any]:
    """Two kitchen episodes of ``random`` and ``bestfirst`` (seed 0), watched by recorders of
    bestfirst's episodes 1 and 2 with a high frame limit, and of its episode 1 with limits 3 and 1."""
    from beliefloc import compile_model
    from beliefloc.belief import uniform
    from beliefloc.render.picture_episode import TraceRecorder
    from beliefloc.semantic_map import load_map
    from beliefloc.simulation.episode import run_experiment

    model = compile_model(load_map(KITCHEN))
    start = uniform(model.n_states)
    recorders = {
        "first": TraceRecorder("bestfirst", 0, start, limit=100),
        "second": TraceRecorder("bestfirst", 1, start, limit=100),
        "three": TraceRecorder("bestfirst", 0, start, limit=3),
        "one": TraceRecorder("bestfirst", 0, start, limit=1),
    }

    def on_step(*args: Any) -> None:
        for recorder in recorders.values():
            recorder.on_step(*args)

    def on_episode(record: Any) -> None:
        for recorder in recorders.values():
            recorder.on_episode(record)

    records = run_experiment(
        model, ["random", "bestfirst"], episodes=2, seed=0, start_belief=start, on_step=on_step, on_episode=on_episode
    )
    traces = {name: recorder.trace for name, recorder in recorders.items()}
    return {"model": model, "records": records, "traces": traces}


def _record(traced: dict[str, Any], episode: int) -> Any:
    (record,) = [r for r in traced["records"] if r.strategy == "bestfirst" and r.episode == episode]
    return record


def test_the_recorder_keeps_the_chosen_episode_of_the_chosen_strategy(traced: dict[str, Any]):
    record, trace = _record(traced, 1), traced["traces"]["second"]
    assert (trace.strategy, trace.episode, trace.steps) == ("bestfirst", 1, record.steps)
    assert [f.step for f in trace.frames] == list(range(record.steps + 1))
    assert trace.true_states == (record.start, *(s.true_state for s in record.trace))
    assert [f.action for f in trace.frames[1:]] == [s.action for s in record.trace]
    assert [f.observation for f in trace.frames[1:]] == [s.observation for s in record.trace]
    assert [float(f.belief.max()) for f in trace.frames[1:]] == [s.max_belief for s in record.trace]


def test_a_limit_keeps_the_start_and_the_last_steps_and_the_whole_true_path(traced: dict[str, Any]):
    record, trace = _record(traced, 0), traced["traces"]["three"]
    assert record.steps > 3
    assert [f.step for f in trace.frames] == [0, record.steps - 1, record.steps]
    assert trace.true_states == traced["traces"]["first"].true_states
    assert [f.step for f in traced["traces"]["one"].frames] == [0]


def test_a_recorder_needs_a_frame():
    from beliefloc.render.picture_episode import TraceRecorder

    with pytest.raises(ValueError, match="at least one frame, got a limit of 0"):
        TraceRecorder("bestfirst", 0, np.ones(2) / 2, limit=0)


def test_frame_titles_tell_the_step():
    from beliefloc.render.picture_episode import EpisodeTrace, TraceFrame, frame_title

    trace = EpisodeTrace("bestfirst", 1, ("a", "b", "c"), ())
    belief = np.ones(2) / 2
    assert frame_title(trace, TraceFrame(0, belief)) == "bestfirst, episode 2, step 0: start belief"
    assert frame_title(trace, TraceFrame(1, belief, "forward")) == "bestfirst, episode 2, step 1: forward"
    looked = TraceFrame(2, belief, "look", "chair+screen", 0.08333)
    assert frame_title(trace, looked) == "bestfirst, episode 2, step 2: look → chair+screen (p = 0.0833)"


def test_every_frame_has_one_colour_scale_and_the_true_path_so_far(
    traced: dict[str, Any], monkeypatch: pytest.MonkeyPatch
):
    from beliefloc.render import picture_episode

    model, trace = traced["model"], traced["traces"]["first"]
    scales: list[float | None] = []
    paths: list[list[int]] = []
    monkeypatch.setattr(picture_episode, "draw_belief", lambda *a, vmax=None, **k: scales.append(vmax))
    monkeypatch.setattr(picture_episode, "draw_path", lambda ax, grid, states, **k: paths.append(list(states)))
    monkeypatch.setattr(picture_episode, "figure_bytes", lambda fig, suffix: b"png")
    assert picture_episode.episode_frames(model, trace) == [b"png"] * len(trace.frames)
    assert scales == [max(float(f.belief.max()) for f in trace.frames)] * len(trace.frames)
    true = [model.states.index(name) for name in trace.true_states]
    assert paths == [true[: k + 1] for k in range(len(trace.frames))]


def test_frames_are_written_whole_or_not_at_all(tmp_path: Path, monkeypatch: pytest.MonkeyPatch):
    from beliefloc.render.picture_episode import save_frames

    written: list[Path] = []
    real = Path.write_bytes

    def failing(self: Path, data: bytes) -> int:
        if len(written) == 2:
            raise OSError("disk full")
        written.append(self)
        return real(self, data)

    monkeypatch.setattr(Path, "write_bytes", failing)
    with pytest.raises(OutputError, match="disk full"):
        save_frames([b"1", b"2", b"3"], tmp_path / "frames")
    assert len(written) == 2  # the failure came mid-way
    assert list(tmp_path.iterdir()) == []


def test_frames_replace_only_a_folder_of_frames(tmp_path: Path):
    from beliefloc.render.picture_episode import frame_name, save_frames

    folder = tmp_path / "frames"
    assert save_frames([b"a", b"b", b"c"], folder)[-1] == folder / "frame-002.png"
    save_frames([b"x"], folder)
    assert [p.read_bytes() for p in sorted(folder.iterdir())] == [b"x"]
    (folder / "notes.txt").write_text("mine")
    with pytest.raises(ValueError, match="not a folder of frames"):
        save_frames([b"y"], folder)
    assert (folder / "notes.txt").read_text() == "mine"
    assert frame_name(7, 12) == "frame-007.png" and frame_name(1234, 1500) == "frame-1234.png"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["frames"]


def test_png_frames_of_the_gif_open(recorded: dict[str, Any]):
    """A frame is a picture (not blank): it has the dark shade of the localized belief at the end."""
    last = _gif_frames(recorded["folder"] / "first.gif")[-1]
    pixels = np.asarray(last)
    assert pixels.min() < 60  # a dark purple triangle, black text
    with Image.open(io.BytesIO((recorded["folder"] / "frames" / "frame-000.png").read_bytes())) as png:
        assert png.mode in ("RGBA", "RGB")
