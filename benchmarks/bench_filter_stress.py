"""The lattice filter under random actions (issue 26): does the truth keep its weight?

A confidently wrong answer needs the belief to lose the robot's true pose. Whole episodes find one in
hundreds (the depot: one in about 400, at 45 s an episode); this looks for the cause directly, with no
planner. Each episode is the continuous robot of ``simulate --continuous`` (started anywhere, motion
noise, range noise, optional clutter) driven by random moves, every reading taken after each move, and
the lattice filter ``localize`` uses following it. After each move and its readings it records:

* the truth's weight: the largest lattice weight within 0.15 m and 0.3 rad of the true pose over the
  largest anywhere (1: the truth is among the most likely poses; the filter drops poses below 1e-12 of
  the best before scoring a measured range, and a truth dropped is never found again except by the
  motion noise's spread);
* whether the filter would declare a state (its reach at the threshold and at most 1 % beyond its
  promise, as ``localize`` asks) that is confidently wrong, and the first action after which it would
  declare a right one (how fast a change to the filter lets it decide: a filter that keeps the truth
  alive by saying little is no better).

Printed per episode (one JSON line), then the lowest truth weights. Run by hand::

    PYTHONPATH=$PWD python benchmarks/bench_filter_stress.py --map depot --episodes 60 --moves 60
    PYTHONPATH=$PWD python benchmarks/bench_filter_stress.py --map depot --episodes 1 --first 21 --verbose

``--verbose`` prints every action: its reading, the truth's weight and the declared probability.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from beliefloc import compile_model, load_map
from beliefloc.belief import uniform
from beliefloc.model import GridLayout
from beliefloc.robots.localize import Command
from beliefloc.simulation.continuous_episode import ContinuousSetup, is_wrong, pose_errors

MAPS = Path(__file__).resolve().parent.parent / "maps"
NEAR_METRES = 0.15
NEAR_RADIANS = 0.3
THRESHOLD = 0.95
ELSEWHERE = 0.01
"""``localize``'s declaration at its default threshold: RIVAL_SHARE x (1 - 0.95)."""


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--map", default="depot")
    parser.add_argument("--clutter", type=float, default=0.0)
    parser.add_argument("--episodes", type=int, default=60)
    parser.add_argument("--first", type=int, default=0)
    parser.add_argument("--moves", type=int, default=60, help="random moves an episode, each followed by every reading")
    parser.add_argument("--seed", type=int, default=7)
    parser.add_argument("--verbose", action="store_true")
    args = parser.parse_args(argv)
    smap = load_map(MAPS / f"{args.map}.yaml")
    model = compile_model(smap)
    grid = model.grid
    assert grid is not None
    setup = ContinuousSetup(smap, clutter=args.clutter, report_odometry=True, lattice=True)
    moves = model.actuation_actions
    readings_after = model.perception_actions
    lows = []
    for episode in range(args.first, args.first + args.episodes):
        started = time.perf_counter()
        robot, reading, _ = setup.robot(model, args.seed, episode)
        binner = setup.binner(model)
        tracker = setup.belief_filter(model)
        assert tracker is not None
        tracker.start(uniform(model.n_states))
        poses = tracker.lattice.pose_array  # the grid frame's (x, y, yaw)
        draw = np.random.default_rng([args.seed, episode])
        lowest, lowest_at, wrong, right_at = 1.0, 0, [], None
        seq = 0
        for move in range(args.moves):
            for action in [moves[int(draw.integers(len(moves)))], *readings_after]:
                seq += 1
                replies = reading.act(Command(seq, action, None, None))
                observation = binner.observation(action, replies)
                tracker.predict(action, reading.motion_report())
                tracker.correct(action, observation, replies)
                weight = truth_weight(tracker.core.fine, poses, grid, robot.pose)
                if args.verbose:
                    seen = "" if observation is None else f" -> {action.observation.name(observation)} {replies}"
                    print(
                        f"{move:3d} {seq:4d} {action.name}{seen} | truth's weight {weight:.3g}, p {tracker.peak():.3f}"
                    )
                if weight < lowest:
                    lowest, lowest_at = weight, seq
            state, p = tracker.declared()
            if p >= THRESHOLD and tracker.elsewhere() <= ELSEWHERE:
                error, yaw = pose_errors(grid, state, robot.pose)
                if is_wrong(grid, error, yaw):
                    wrong.append({"action": seq, "p": round(p, 4), "metres_off": round(error, 2)})
                elif right_at is None:
                    right_at = seq
        lows.append((lowest, episode, lowest_at))
        print(
            json.dumps(
                {
                    "episode": episode,
                    "truth_weight_lowest": lowest,
                    "at_action": lowest_at,
                    "wrong_declarations": wrong[:5],
                    "first_right_declaration": right_at,
                    "seconds": round(time.perf_counter() - started, 1),
                }
            ),
            flush=True,
        )
    lows.sort()
    print("lowest truth weights (weight, episode, action):", [(f"{w:.2g}", e, a) for w, e, a in lows[:8]])
    return 0


def truth_weight(fine: np.ndarray, poses: np.ndarray, grid: GridLayout, pose: np.ndarray) -> float:
    """The largest lattice weight near the true ``pose`` (map frame) over the largest anywhere."""
    gx, gy = grid.frame.to_grid(pose[0], pose[1])
    gyaw = pose[2] - grid.frame.yaw
    near = (np.hypot(poses[:, 0] - gx, poses[:, 1] - gy) <= NEAR_METRES) & (
        np.abs((poses[:, 2] - gyaw + np.pi) % (2 * np.pi) - np.pi) <= NEAR_RADIANS
    )
    return float(fine[near].max() / fine.max()) if near.any() else 0.0


if __name__ == "__main__":
    sys.exit(main())
