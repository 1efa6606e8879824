"""Belief files: ``{state: probability}`` in YAML or JSON, validated against a model's states.

Missing states get 0. ``"row,col"`` on a map with headings names the whole cell, its probability
split evenly over the headings. A file whose probabilities do not sum to 1 is normalised and a
warning is returned; every probability must be a finite number >= 0, and their sum finite (1e308
twice is not) and positive, else the error names the line. The output of ``beliefloc track
--json`` (``{"belief": {...}, ...}``) is accepted too, so a tracked belief can be fed to the next
command.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, RootModel

from beliefloc.errors import BeliefFileError, InvalidValueError
from beliefloc.model import Model
from beliefloc.source import Source, read_source, validate_source

if TYPE_CHECKING:
    from beliefloc.pose import PoseEstimate

_SUM_TOLERANCE = 1e-6


class _BeliefMapping(RootModel[dict[str, Annotated[float, Field(ge=0.0, allow_inf_nan=False, strict=True)]]]):
    pass


def load_belief(model: Model, path: str | Path) -> tuple[np.ndarray, list[str]]:
    """The belief in ``path`` as a vector over ``model``'s states, and any warnings."""
    return _belief_in(model, _read_belief_file(path))


def load_belief_and_pose(model: Model, path: str | Path) -> tuple[np.ndarray, list[str], PoseEstimate | None]:
    """:func:`load_belief` and :func:`load_belief_pose` from one reading of the file."""
    source = _read_belief_file(path)
    belief, warnings = _belief_in(model, source)
    return belief, warnings, _pose_in(model, source, belief)


def _read_belief_file(path: str | Path) -> Source:
    from beliefloc.source import file_kinds

    by_suffix = file_kinds.kind_of_path(path)
    if by_suffix is not None:
        raise BeliefFileError(file_kinds.not_a(path, by_suffix, file_kinds.BELIEF))
    return read_source(path, BeliefFileError)


def _belief_in(model: Model, source: Source) -> tuple[np.ndarray, list[str]]:
    from beliefloc.source import file_kinds

    path = source.path
    data = source.data
    found = file_kinds.kind_of_data(data)
    if found is not None and found != file_kinds.BELIEF:
        raise BeliefFileError(file_kinds.not_a(path, found, file_kinds.BELIEF))
    prefix: tuple[str, ...] = ()
    if isinstance(data, dict) and isinstance(data.get("belief"), dict):
        data, prefix = data["belief"], ("belief",)
    inner = Source(
        source.path, data, source.sha256, _strip(source.value_marks, prefix), _strip(source.key_marks, prefix)
    )
    if not isinstance(data, dict):
        raise BeliefFileError(f"{source.path}:1:1: a belief file maps states to probabilities, e.g. {{'0,0,1': 0.5}}")
    mapping = validate_source(inner, _BeliefMapping, BeliefFileError).root
    belief = np.zeros(model.n_states)
    running = 0.0
    for name, probability in mapping.items():
        try:
            states = model.states.indices(str(name))
        except InvalidValueError as exc:
            raise inner.error((str(name),), str(exc), BeliefFileError, key=True) from None
        running += probability
        if not math.isfinite(running):
            raise inner.error(
                (str(name),),
                f"the probabilities add up to more than {sys.float_info.max:.4g}, the largest number there is; "
                "give probabilities (at most 1 each), or smaller weights",
                BeliefFileError,
            )
        belief[states] += probability / len(states)
    total = float(belief.sum())
    if not total > 0.0 or not math.isfinite(total):
        raise inner.error((), "every probability is 0; a belief needs some mass", BeliefFileError)
    warnings = []
    if abs(total - 1.0) > _SUM_TOLERANCE:
        warnings.append(f"{source.path}: probabilities sum to {total:.6g}, not 1; normalised")
    return belief / total, warnings


def _strip(
    marks: dict[tuple[str | int, ...], tuple[int, int]], prefix: tuple[str, ...]
) -> dict[tuple[str | int, ...], tuple[int, int]]:
    if not prefix:
        return marks
    n = len(prefix)
    return {key[n:]: mark for key, mark in marks.items() if key[:n] == prefix}


# --- the pose a localize run wrote beside its belief ---------------------------------------------

POSE_KEY = "localized_pose"
"""The key of the pose ``localize --belief-out`` writes beside the belief (``track``'s output has a
``"pose"`` of its own, read by nobody here)."""
PROMISE_CELLS = 1.5
"""Cells: how far from its state's cell centre a pose written beside a belief may lie (the pose
lattice's promise: :data:`beliefloc.continuous.pose_lattice.PROMISE_CELLS`)."""


class _ReportedPose(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True)

    state: str
    x: Annotated[float, Field(allow_inf_nan=False)]
    y: Annotated[float, Field(allow_inf_nan=False)]
    yaw: Annotated[float, Field(allow_inf_nan=False)]
    covariance: Annotated[list[Annotated[float, Field(allow_inf_nan=False)]], Field(min_length=36, max_length=36)]
    probability: Annotated[float, Field(gt=0.0, le=1.0, allow_inf_nan=False)] | None = None


class _PoseBeside(BaseModel):
    model_config = ConfigDict(extra="ignore")

    localized_pose: _ReportedPose | None = None


def load_belief_pose(model: Model, path: str | Path, belief: np.ndarray) -> PoseEstimate | None:
    """The pose ``localize --belief-out`` wrote beside the belief in ``path`` (under :data:`POSE_KEY`:
    the pose lattice's estimate, finer than a state's centre, and the probability it was declared at:
    that the robot is within one cell and 3/4 of a sector of the state), checked against ``model`` and
    ``belief`` (the file's, as :func:`load_belief` read it); None when the file has none. Refused,
    naming the line and field: a state that is not the belief's most likely one (the belief was
    edited, or the pose copied from another run), a pose more than :data:`PROMISE_CELLS` cells from
    that state's centre or more than one heading sector from its heading, a probability above the
    belief's mass in the state's place (:func:`beliefloc.pose.belief_modes`), a covariance that is
    not symmetric or has a negative variance."""
    return _pose_in(model, read_source(path, BeliefFileError), belief)


def _pose_in(model: Model, source: Source, belief: np.ndarray) -> PoseEstimate | None:
    from beliefloc.pose import Pose, PoseEstimate, belief_modes, state_pose

    data = source.data
    if not isinstance(data, dict) or POSE_KEY not in data:
        return None
    reported = validate_source(source, _PoseBeside, BeliefFileError).localized_pose
    if reported is None:
        return None
    grid = model.grid
    if grid is None:
        raise source.error((POSE_KEY,), f"model {model.name} has no grid, so its states have no pose", BeliefFileError)
    try:
        state = model.states.index(reported.state)
    except InvalidValueError as exc:
        raise source.error((POSE_KEY, "state"), str(exc), BeliefFileError) from None
    likeliest = int(np.argmax(belief))
    if state != likeliest:
        raise source.error(
            (POSE_KEY, "state"),
            f"{reported.state!r} is not the belief's most likely state {model.states.name(likeliest)!r}: the pose "
            "was written with another belief (localize --belief-out writes both; drop the pose to use the "
            "belief alone)",
            BeliefFileError,
        )
    centre = state_pose(grid, state)
    apart = math.hypot(reported.x - centre.x, reported.y - centre.y)
    if apart > PROMISE_CELLS * grid.cell_size + 1e-9:
        raise source.error(
            (POSE_KEY, "x"),
            f"({reported.x:g}, {reported.y:g}) is {apart:.3g} m from state {reported.state}'s cell centre "
            f"({centre.x:g}, {centre.y:g}), more than {PROMISE_CELLS} cells",
            BeliefFileError,
        )
    sector = 2 * math.pi / grid.headings
    if grid.headings > 1 and abs(math.remainder(reported.yaw - centre.yaw, 2 * math.pi)) > sector + 1e-9:
        raise source.error(
            (POSE_KEY, "yaw"),
            f"{reported.yaw:g} rad is more than one heading sector from state {reported.state}'s heading "
            f"({centre.yaw:g} rad)",
            BeliefFileError,
        )
    probability = float(belief[state]) if reported.probability is None else reported.probability
    place = next((m.probability for m in belief_modes(model, belief) if m.state == state), 0.0)
    if probability > place + 1e-9:
        raise source.error(
            (POSE_KEY, "probability"),
            f"{probability:g} is more than the belief holds around state {reported.state} ({place:.6g}, its place "
            "within 1.5 cells): the pose was written with another belief",
            BeliefFileError,
        )
    cov = np.array(reported.covariance).reshape(6, 6)
    scale = max(1.0, float(np.abs(cov).max()))
    if not np.allclose(cov, cov.T, rtol=0.0, atol=1e-9 * scale) or np.diag(cov).min() < 0.0:
        raise source.error(
            (POSE_KEY, "covariance"),
            "not a covariance: 36 numbers row-major over (x, y, z, rot_x, rot_y, rot_z), symmetric, no negative "
            "variance on the diagonal",
            BeliefFileError,
        )
    return PoseEstimate(Pose(reported.x, reported.y, reported.yaw), tuple(reported.covariance), state, probability)
