"""An episode as an animation: the belief after every step, the true pose and the true path so far,
the step's action and observation as the title -- a frame per step, as PNG bytes for a GIF
(:func:`beliefloc.render.figures.save_gif`) or a folder of numbered PNGs (:func:`save_frames`).

Rendering only observes: :class:`TraceRecorder` is handed to
:func:`beliefloc.simulation.episode.run_experiment`'s ``on_step`` and ``on_episode`` hooks and keeps
the trace of one episode (:class:`EpisodeTrace`); :func:`episode_frames` draws the trace afterwards,
with :mod:`beliefloc.render.picture_belief`'s functions. matplotlib is reached only through
:mod:`beliefloc.render.figures`.

* **Which frames.** Frame 0 is the start belief, frame n the belief after step n. An episode longer
  than the frame limit keeps its start and its *last* ``limit - 1`` steps (where it localizes, or
  how it ends); the titles' step numbers show the jump.
* **Comparable frames.** Every frame of an animation has the same size in pixels and the same colour
  scale, 0 to the largest probability of any kept frame, so that a shade means the same in each.
"""

from __future__ import annotations

import collections
import os
import re
import shutil
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from beliefloc.render.figures import figure, figure_bytes
from beliefloc.render.picture_belief import belief_figure, draw_belief, draw_path, mark_pose

if TYPE_CHECKING:
    from beliefloc.model import Model
    from beliefloc.semantic_map import SemanticMap
    from beliefloc.simulation.episode import EpisodeRecord, StepRecord

FRAME_PATTERN = re.compile(r"frame-\d{3,}\.png")
"""The names :func:`save_frames` gives: ``frame-000.png``, ``frame-001.png``, … (more digits past 999)."""
_LEGEND_ROW_INCHES = 0.2
"""A frame's two legend entries more than :func:`belief_figure`'s (true path, true pose): one row at most."""


@dataclass(frozen=True)
class TraceFrame:
    """One frame's data: the belief after step ``step`` (0: the start belief) and what the step was."""

    step: int
    belief: np.ndarray
    """``belief[i] = b(s_i)`` after the step."""
    action: str | None = None
    observation: str | None = None
    """None after an actuation (it observes nothing) and in frame 0."""
    probability: float | None = None
    """``p(o | a, b)``: how likely the observation was under the belief before the step."""


@dataclass(frozen=True)
class EpisodeTrace:
    """What an animation of one episode shows. ``true_states[n]`` is the robot's true state after
    step n (``true_states[0]`` its start) for *every* step, so that a frame's true path is whole even
    when frames were left out; ``frames`` are the kept frames, in step order."""

    strategy: str
    episode: int
    """0-based, as :class:`~beliefloc.simulation.episode.EpisodeRecord` counts (the terminal prints ``episode + 1``)."""
    true_states: tuple[str, ...]
    frames: tuple[TraceFrame, ...]

    @property
    def steps(self) -> int:
        """How many steps the episode took (frames may be fewer)."""
        return len(self.true_states) - 1


class TraceRecorder:
    """Keeps the trace of episode ``episode`` (0-based) of strategy ``strategy`` while
    :func:`~beliefloc.simulation.episode.run_experiment` runs: pass :meth:`on_step` and
    :meth:`on_episode` to its hooks. At most ``limit`` frames are kept (the start belief and the last
    ``limit - 1`` steps), so memory stays bounded whatever the episode's length. The beliefs handed
    to the hook are kept as they are (the simulation makes a new array every step)."""

    def __init__(self, strategy: str, episode: int, start_belief: np.ndarray, *, limit: int):
        if limit < 1:
            raise ValueError(f"an animation needs at least one frame, got a limit of {limit}")
        self.strategy = strategy
        self.episode = episode
        self._start = TraceFrame(0, start_belief)
        self._recent: collections.deque[TraceFrame] = collections.deque(maxlen=limit - 1)
        self._true_states: list[str] = []
        self._trace: EpisodeTrace | None = None

    def _mine(self, record: EpisodeRecord) -> bool:
        return record.strategy == self.strategy and record.episode == self.episode

    def on_step(self, record: EpisodeRecord, step: StepRecord, belief: np.ndarray) -> None:
        """``run_experiment``'s ``on_step``: called after every step of every episode."""
        if not self._mine(record):
            return
        if not self._true_states:
            self._true_states.append(record.start)
        self._true_states.append(step.true_state)
        if self._recent.maxlen:
            self._recent.append(TraceFrame(record.steps, belief, step.action, step.observation, step.probability))

    def on_episode(self, record: EpisodeRecord) -> None:
        """``run_experiment``'s ``on_episode``: called when an episode ends."""
        if not self._mine(record):
            return
        true_states = tuple(self._true_states) if self._true_states else (record.start,)
        self._trace = EpisodeTrace(self.strategy, self.episode, true_states, (self._start, *self._recent))

    @property
    def trace(self) -> EpisodeTrace | None:
        """The trace once the episode has ended; None before (or when it never ran)."""
        return self._trace


def frame_title(trace: EpisodeTrace, frame: TraceFrame) -> str:
    """``"bestfirst, episode 2, step 3: look → chair (p = 0.083)"``; frame 0 says ``start belief``."""
    head = f"{trace.strategy}, episode {trace.episode + 1}, step {frame.step}"
    if frame.action is None:
        return f"{head}: start belief"
    if frame.observation is None:
        return f"{head}: {frame.action}"
    return f"{head}: {frame.action} → {frame.observation} (p = {frame.probability:.3g})"


def episode_frames(model: Model, trace: EpisodeTrace, *, smap: SemanticMap | None = None) -> list[bytes]:
    """Every kept frame of ``trace`` as PNG bytes: :func:`draw_belief` of the frame's belief, the true
    path from the start to the frame's step (:func:`draw_path`, style ``"true"``), the true pose
    (:func:`mark_pose`), :func:`frame_title` as the title. One figure size and one colour scale for
    all frames (0 to the largest probability of any of them). Raises ValueError for a model without a grid."""
    if model.grid is None:
        raise ValueError(f"model {model.name!r} has no grid to draw")
    grid = model.grid
    states = [model.states.index(name) for name in trace.true_states]
    vmax = max(float(frame.belief.max()) for frame in trace.frames)
    with belief_figure(model, trace.frames[0].belief, smap=smap) as sized:  # its size; nothing is rendered
        width, height = (float(v) for v in sized.get_size_inches())
    height += _LEGEND_ROW_INCHES
    pictures = []
    for frame in trace.frames:
        with figure(width, height) as fig:
            fig.set_layout_engine("constrained")
            ax = fig.add_subplot()
            draw_belief(ax, model, frame.belief, smap=smap, vmax=vmax)
            draw_path(ax, grid, states[: frame.step + 1], style="true")
            mark_pose(ax, grid, states[frame.step], label=f"true state {trace.true_states[frame.step]}")
            ax.set_title(frame_title(trace, frame), fontsize=10)
            pictures.append(figure_bytes(fig, ".png"))
    return pictures


def frame_name(index: int, count: int) -> str:
    """``frame-007.png``: three digits, more when ``count`` frames need them (names sort in order)."""
    return f"frame-{index:0{max(3, len(str(count - 1)))}d}.png"


def holds_only_frames(directory: Path) -> bool:
    """``directory`` holds nothing but :func:`save_frames`' files (an earlier recording, or nothing),
    so writing frames there loses nothing else."""
    return all(entry.is_file() and FRAME_PATTERN.fullmatch(entry.name) for entry in directory.iterdir())


def save_frames(frames: Sequence[bytes], directory: Path) -> list[Path]:
    """Write PNG ``frames`` as ``directory/frame-000.png``, … whole or not at all: they are written
    into a new temporary folder beside ``directory``, which is then renamed into place. An existing
    ``directory`` must hold nothing but frames (:func:`holds_only_frames`): it is replaced whole
    (moved aside, the new folder renamed in, the old one deleted). Returns the files written."""
    if not frames:
        raise ValueError("an animation needs at least one frame")
    directory = Path(directory)
    parent = directory.parent if str(directory.parent) else Path(".")
    if directory.exists() and not (directory.is_dir() and holds_only_frames(directory)):
        raise ValueError(f"{directory}: not a folder of frames; refusing to replace it")
    try:
        staging = Path(tempfile.mkdtemp(prefix=f".{directory.name}.", suffix=".tmp", dir=parent))
    except OSError as exc:
        from beliefloc.errors import OutputError

        raise OutputError(f"{directory}: cannot be written ({exc.strerror or exc}); nothing was written") from None
    try:
        staging.chmod(_folder_mode())  # as mkdir would create it, not mkdtemp's private 0700
        for index, data in enumerate(frames):
            (staging / frame_name(index, len(frames))).write_bytes(data)
        _swap_into_place(staging, directory, parent)
    except OSError as exc:
        from beliefloc.errors import OutputError

        shutil.rmtree(staging, ignore_errors=True)
        raise OutputError(f"{directory}: cannot be written ({exc.strerror or exc}); nothing was written") from None
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        raise
    return [directory / frame_name(index, len(frames)) for index in range(len(frames))]


def _swap_into_place(staging: Path, directory: Path, parent: Path) -> None:
    """Rename ``staging`` to ``directory``; an existing ``directory`` is moved aside first and
    deleted after (put back if the rename fails)."""
    if not directory.exists():
        os.rename(staging, directory)
        return
    old = Path(tempfile.mkdtemp(prefix=f".{directory.name}.", suffix=".old", dir=parent))
    os.rename(directory, old / "frames")
    try:
        os.rename(staging, directory)
    except BaseException:
        os.rename(old / "frames", directory)
        shutil.rmtree(old, ignore_errors=True)
        raise
    shutil.rmtree(old, ignore_errors=True)


def _folder_mode() -> int:
    """0o777 less the umask."""
    umask = os.umask(0)
    os.umask(umask)
    return 0o777 & ~umask
