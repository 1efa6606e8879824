"""``pose``: a belief as a map-frame pose with a covariance, e.g. an initial pose for Nav2's AMCL."""

from __future__ import annotations

import enum
import re
import sys
from typing import TYPE_CHECKING, Annotated, Literal

import typer

from beliefloc.cli.common import boundary, initial_belief_and_pose, open_model, print_json
from beliefloc.cli.options import BeliefOption, ModelArgument, number
from beliefloc.errors import EXIT_NEGATIVE
from beliefloc.planning.settings import DEFAULT_THRESHOLD
from beliefloc.render import stderr_console

if TYPE_CHECKING:
    from beliefloc.model import Model
    from beliefloc.pose import Localization

DEFAULT_SECOND_MODE_SHARE = 0.05
"""``beliefloc.pose.SECOND_MODE_SHARE``, copied so that ``--help`` loads no numpy (a test checks the two agree)."""
_SECONDS = re.compile(r"^(\d{1,12})(?:\.(\d{1,9}))?$")


class PoseFormat(str, enum.Enum):
    """How ``pose`` prints."""

    JSON = "json"
    """The most likely state, its probability, ``"pose"`` (as ``show --json``'s ``most_likely``), the
    verdict and the modes."""
    ROS = "ros"
    """The YAML body of a ``geometry_msgs/msg/PoseWithCovarianceStamped`` (for ``ros2 topic pub``)."""
    POSEARRAY = "posearray"
    """The YAML body of a ``geometry_msgs/msg/PoseArray``: one pose per mode, most probable first."""


def stamp_ns(text: str) -> int | Literal["now"]:
    """``--stamp``: ``now`` (ros2cli fills in the time it publishes at) or seconds since the epoch,
    ``SEC[.FRACTION]`` (up to 9 decimals, read exactly), as nanoseconds."""
    if text == "now":
        return "now"
    match = _SECONDS.match(text)
    if match is None:
        raise typer.BadParameter(
            f"{text!r}: should be 'now' or seconds since the epoch, e.g. 1700000000.25 (0: no time, tf2's latest)"
        )
    whole, fraction = match.group(1), match.group(2) or ""
    return int(whole) * 1_000_000_000 + int(fraction.ljust(9, "0"))


def _checked_stamp(text: str) -> str:
    stamp_ns(text)
    return text


@boundary
def pose_command(
    source: ModelArgument,
    belief: BeliefOption = "uniform",
    output: Annotated[
        PoseFormat,
        typer.Option(
            "--format",
            help="json: the most likely state, its probability, its pose with the belief's covariance, the "
            "verdict and the modes; ros: the YAML body of a geometry_msgs/msg/PoseWithCovarianceStamped for "
            "/initialpose; posearray: the YAML body of a geometry_msgs/msg/PoseArray, one pose per mode.",
        ),
    ] = PoseFormat.JSON,
    frame_id: Annotated[
        str,
        typer.Option("--frame-id", metavar="FRAME", help="The header's frame_id in --format ros (the map's frame)."),
    ] = "map",
    stamp: Annotated[
        str,
        typer.Option(
            "--stamp",
            metavar="now|SECONDS",
            parser=_checked_stamp,
            help="The header's stamp: now (ros2 topic pub fills in the time it publishes at) or seconds since "
            "the epoch (the time of the readings the belief comes from; AMCL then accounts for the motion since).",
        ),
    ] = "now",
    min_probability: Annotated[
        float,
        typer.Option(
            "--min-probability",
            parser=number(low=0.0, high=1.0),
            metavar="P",
            help="--format ros refuses a belief whose most likely state holds less (the planners' goal).",
        ),
    ] = DEFAULT_THRESHOLD,
    second_mode: Annotated[
        float,
        typer.Option(
            "--max-second-mode",
            parser=number(low=0.0, high=1.0),
            metavar="SHARE",
            help="--format ros refuses a belief whose second mode holds more than this share.",
        ),
    ] = DEFAULT_SECOND_MODE_SHARE,
    force: Annotated[
        bool,
        typer.Option("--force", help="Print the --format ros message for a belief that is not localized."),
    ] = False,
) -> None:
    """The belief as a pose in the map frame: the most likely state's cell centre and heading yaw,
    and the belief's covariance over (x, y, yaw) in ROS's 6x6 row-major layout.

    The covariance is about the belief's mean (circular for the yaw) and includes the spread within
    a cell and within a heading sector, so it is never singular. A model without a grid (an
    imported .pomdp) has no poses: exit 2.

    A belief file that localize --belief-out wrote with the pose lattice carries the finer pose
    beside the belief (a few centimetres and degrees off, not a cell centre) and the probability it
    was declared at: that pose is printed, and that probability is what --min-probability is
    compared with. It is checked against the belief (exit 2 naming the field when it does not fit).

    --format ros is an initial pose for Nav2's AMCL (Humble, Jazzy, Kilted and Rolling accept it):
    frame_id map, stamp now unless --stamp, every number rounded to 9 decimals, and no negative
    covariance entry (Rolling refuses one: a negative correlation c is set to 0 and |c| added to both
    variances, which widens the seeded spread and never narrows it). AMCL seeds one Gaussian, so a
    belief that is not one place is refused (exit 1, with its modes): the most likely state below
    --min-probability, or a second mode above --max-second-mode. No --belief is the uniform belief:
    refused too. --force prints it anyway. --format posearray prints the modes instead, to seed a
    particle filter with several places.

    Examples:

    \b
      echo '{"0,1,0": 0.97, "1,1,0": 0.03}' > belief.json
      beliefloc pose maps/kitchen.yaml --belief belief.json
      beliefloc pose maps/kitchen.yaml --belief belief.json --format ros > initialpose.yaml
      beliefloc track maps/kitchen.yaml --json look=nothing > early.json
      beliefloc pose maps/kitchen.yaml --belief early.json --format ros   # exits 1: two places
      beliefloc pose maps/kitchen.yaml --belief early.json --format posearray

    Then, on a ROS 2 machine, set the robot's initial pose (Nav2's AMCL listens on /initialpose):

    \b
      ros2 topic pub --once /initialpose geometry_msgs/msg/PoseWithCovarianceStamped "$(cat initialpose.yaml)"
    """
    import yaml

    from beliefloc.pose import belief_pose, for_amcl, localization
    from beliefloc.ros.messages import pose_array, pose_with_covariance_stamped, rounded

    model = open_model(source)
    start, written = initial_belief_and_pose(model, belief)  # written: a localize run's own pose, beside its belief
    estimate = written if written is not None else belief_pose(model, start)
    verdict = localization(
        model, start, min_probability=min_probability, second_mode_share=second_mode, declared=written
    )
    ns = stamp_ns(stamp)
    if output is PoseFormat.POSEARRAY:
        body = rounded(pose_array([m.pose for m in verdict.modes], frame_id=frame_id, ns=ns))
        sys.stdout.write(yaml.safe_dump(body, default_flow_style=None, sort_keys=False, width=100))
        return
    if output is PoseFormat.ROS:
        if not verdict.localized and not force:
            _refuse(model, verdict, belief, min_probability, second_mode)
        body = rounded(pose_with_covariance_stamped(for_amcl(estimate), frame_id=frame_id, ns=ns))
        sys.stdout.write(yaml.safe_dump(body, default_flow_style=None, sort_keys=False, width=100))
        return
    print_json(
        {
            "state": model.states.name(estimate.state),
            "probability": estimate.probability,
            "pose": estimate.as_json(),
            **verdict.as_json(),
        }
    )


def _refuse(model: Model, verdict: Localization, belief: str, min_probability: float, second_mode: float) -> None:
    """Exit 1 with why the belief is not one place, and its modes."""
    from rich.markup import escape

    modes = "; ".join(
        f"{model.states.name(m.state)} at ({m.pose.x:.3f}, {m.pose.y:.3f}, yaw {m.pose.yaw:.3f}) holds "
        f"{m.probability:.3g} ({m.states} state{'' if m.states == 1 else 's'})"
        for m in verdict.modes
    )
    given = "no --belief given, so the uniform belief: " if belief == "uniform" else ""
    why = "; ".join(verdict.reasons)
    stderr_console().print(
        escape(
            f"not localized: {given}{why} (--min-probability {min_probability:g}, --max-second-mode "
            f"{second_mode:g}). AMCL would seed one Gaussian over every place below. Modes: {modes}. "
            "--format posearray prints them as poses; --force prints the pose anyway."
        ),
        soft_wrap=True,
    )
    raise typer.Exit(EXIT_NEGATIVE)


def register(app: typer.Typer) -> None:
    app.command("pose", short_help="The belief as a map-frame pose with its covariance.")(pose_command)
