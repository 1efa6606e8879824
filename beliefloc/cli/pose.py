"""``pose``: a belief as a map-frame pose with a covariance, e.g. an initial pose for Nav2's AMCL."""

from __future__ import annotations

import enum
import sys
from typing import Annotated

import typer

from beliefloc.cli.common import boundary, initial_belief, open_model, print_json
from beliefloc.cli.options import BeliefOption, ModelArgument


class PoseFormat(str, enum.Enum):
    """How ``pose`` prints."""

    JSON = "json"
    """The most likely state, its probability and ``"pose"`` (as ``show --json``'s ``most_likely``)."""
    ROS = "ros"
    """The YAML body of a ``geometry_msgs/msg/PoseWithCovarianceStamped`` (for ``ros2 topic pub``)."""


@boundary
def pose_command(
    source: ModelArgument,
    belief: BeliefOption = "uniform",
    output: Annotated[
        PoseFormat,
        typer.Option(
            "--format",
            help="json: the most likely state, its probability and its pose with the belief's covariance; "
            "ros: the YAML body of a geometry_msgs/msg/PoseWithCovarianceStamped.",
        ),
    ] = PoseFormat.JSON,
    frame_id: Annotated[
        str,
        typer.Option("--frame-id", metavar="FRAME", help="The header's frame_id in --format ros (the map's frame)."),
    ] = "map",
) -> None:
    """The belief as a pose in the map frame: the most likely state's cell centre and heading yaw,
    and the belief's covariance over (x, y, yaw) in ROS's 6x6 row-major layout.

    The covariance is about the belief's mean (circular for the yaw) and includes the spread within
    a cell and within a heading sector, so it is never singular. A model without a grid (an
    imported .pomdp) has no poses: exit 2.

    Examples:

    \b
      beliefloc track maps/kitchen.yaml --json look=nothing > belief.json
      beliefloc pose maps/kitchen.yaml --belief belief.json
      beliefloc pose maps/kitchen.yaml --belief belief.json --format ros > initialpose.yaml

    Then, on a ROS 2 machine, set the robot's initial pose (Nav2's AMCL listens on /initialpose):

    \b
      ros2 topic pub --once /initialpose geometry_msgs/msg/PoseWithCovarianceStamped "$(cat initialpose.yaml)"
    """
    import yaml

    from beliefloc.pose import belief_pose
    from beliefloc.ros.messages import pose_with_covariance_stamped

    model = open_model(source)
    start = initial_belief(model, belief)
    estimate = belief_pose(model, start)
    if output is PoseFormat.ROS:
        body = pose_with_covariance_stamped(estimate, frame_id=frame_id)
        sys.stdout.write(yaml.safe_dump(body, default_flow_style=None, sort_keys=False, width=100))
        return
    print_json(
        {
            "state": model.states.name(estimate.state),
            "probability": estimate.probability,
            "pose": estimate.as_json(),
        }
    )


def register(app: typer.Typer) -> None:
    app.command("pose", short_help="The belief as a map-frame pose with its covariance.")(pose_command)
