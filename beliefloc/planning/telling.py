"""Telling a few look-alike places apart: the cheapest way to a reading that separates them.

Pure numpy, no I/O.

Khalvati & Mackworth's pairwise action selection: when the belief is down to a few hypotheses, lead
them all (the robot is at one of them) along the same actions to where a reading tells them apart,
by the cheapest such sequence -- a macro action (:mod:`beliefloc.planning.macros`). The paper's
macros end where the pair's *noise-free* readings differ. A real robot's readings are noisy: on
tb3-sandbox, the 180° mirror twins of the arena's centre differ by a pixel or two of saved wall,
enough to move a noise-free reading across a bin edge, and a laser with 2 cm of error reads the same
there from both. Here a macro ends where a reading is *expected to tell* which of the places the robot
is at, by the units and tables the caller trusts (the pose lattice's poses and reading tables:
:meth:`beliefloc.robots.belief_filter.LatticeFilter.macro_graph`):

* each place is a few units (states or lattice poses) weighed by the belief; the places move
  together, each unit by its successor under the action (``f*(s, a)``, Eq. 12, for states);
* at each node (the places after a sequence of moves), each reading not yet taken there is worth
  the evidence it is expected to give for the true place (:func:`which_place_evidence`: the mean
  log-likelihood ratio against the other places), up to the evidence still ``needed`` to reach the
  goal (:func:`needed_evidence`), over the cost of the moves and the reading: a reading that settles
  the question is worth going for, one that nudges it is worth its cost only nearby;
* the best worths found win; the search is Dijkstra's over the nodes by the moves' cost, a cost
  at a time with numpy, and stops once no node farther away could beat them (a reading is worth at
  most what is needed).
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

NEAR_COST = 4.0
"""Up to this cost from the start, a node's moves found blocked where it leads are not tried (turned
round on the spot, the robot faces the way a move was found blocked)."""
MAX_NODES = 20_000
"""The most nodes one search settles (the depot's 49,592 states: the bound usually stops it sooner)."""


@dataclass(frozen=True)
class TellingMacro:
    """Moves (action indices, perhaps none), then a reading that tells the places apart."""

    moves: tuple[int, ...]
    reading: int
    evidence: float
    """Nats of log-likelihood ratio the reading is expected to give for the true place."""
    cost: float
    """The moves' and the reading's cost."""


def which_place_evidence(tables: Sequence[np.ndarray], weights: np.ndarray) -> float:
    """The evidence (nats) one reading is expected to give for the place the robot is at, among
    places weighed ``weights`` (summing to 1): ``Σ_i w_i KL(P_i || Q_i)``, the mean log-likelihood
    ratio of the true place's readings ``P_i`` against the other places' mixture ``Q_i``.
    ``tables``: one ``(n_places, n_values)`` table per part of the reading (row ``i``: place ``i``'s
    reading distribution), the parts counted as independent (their divergences add)."""
    return float(
        _evidence([np.asarray(t, dtype=np.float64)[None] for t in tables], np.asarray(weights, dtype=np.float64))[0]
    )


def needed_evidence(weights: np.ndarray, goal: float) -> float:
    """The evidence (nats of log-likelihood ratio) that takes the likeliest of places weighed
    ``weights`` to ``goal``: its log-odds at the goal less its log-odds now (0 once there)."""
    likeliest = float(np.max(weights))
    if not likeliest < goal < 1.0:
        return 0.0
    return math.log(goal / (1.0 - goal)) - math.log(likeliest / (1.0 - likeliest))


Place = tuple[np.ndarray, np.ndarray]
"""A look-alike place: its units (states or lattice poses) and the belief's mass on each."""


def telling_macros(
    fstar: np.ndarray,
    costs: np.ndarray,
    moves: Sequence[int],
    readings: Mapping[int, Sequence[np.ndarray]],
    places: Sequence[Place],
    goal: float,
    taken: Callable[[tuple[int, ...]], set[int]] | None = None,
    *,
    count: int = 1,
    max_nodes: int = MAX_NODES,
) -> list[TellingMacro]:
    """The ``count`` macros that tell ``places`` apart best per unit of cost (see the module), the
    best first (each a different node or reading); none when no reading within reach is expected
    to tell anything.

    ``fstar``: ``(n_actions, n_units)``, each unit's successor under each action (states' most
    likely successors, or lattice poses'); ``costs``: per action; ``moves`` and ``readings``: the
    actuation actions to lead the places along, and the perception actions with their part tables
    by unit; ``places``: each a few neighbouring units with the belief's mass on each (a place
    reads as the mixture of its units: compared unit by unit, two mirror places whose likeliest
    cells are not exact mirrors of each other look told apart by readings that cannot); ``goal``:
    the probability one place should reach (the evidence needed: its log-odds less the likeliest
    place's); ``taken(moves)``: the actions already done where those
    moves lead: a reading taken there is not offered there again, and a move found blocked where
    the robot stands, or where moves of at most :data:`NEAR_COST` lead, is not tried there."""
    if len(places) < 2 or not readings:
        return []
    masses = np.array([float(m.sum()) for _, m in places])
    weights = masses / masses.sum()
    shares = [m / m.sum() for _, m in places]
    keys = [int(np.argmax(m)) for _, m in places]  # a place is known by its likeliest state
    cap = needed_evidence(weights, goal)
    if not cap > 0:
        return []
    cheapest_reading = min(float(costs[r]) for r in readings)
    here = taken(()) if taken is not None else set()
    found: list[tuple[float, int, int, TellingMacro]] = []  # a min-heap of the best: worth, node, reading
    n = fstar.shape[1]

    def bar() -> float:  # the worth a macro must beat to be among the best
        return found[0][0] if len(found) >= count else 0.0

    radix = n ** np.arange(len(places), dtype=np.int64)  # a node's key: its places' likeliest states

    def key_of(members: Sequence[np.ndarray]) -> np.ndarray:
        out: np.ndarray = sum(
            (m[:, k] * r for m, k, r in zip(members, keys, radix, strict=True)), np.zeros(1, np.int64)
        )
        return out

    parents: list[int] = []  # per settled node: the node it was reached from (-1: the start), and the move
    moved: list[int] = []

    def path_to(node: int) -> tuple[int, ...]:
        path = []
        while moved[node] >= 0:  # the start's move is -1
            path.append(moved[node])
            node = parents[node]
        return tuple(reversed(path))

    # Dijkstra a cost at a time: the nodes first reached at one cost are weighed and expanded
    # together, as arrays. A level's chunk: (keys, members per place, parent node, move)
    start = tuple(np.asarray(s, dtype=np.int64)[None, :] for s, _ in places)
    levels = {0.0: [(key_of(start), start, np.array([-1]), -1)]}
    pending = [0.0]
    settled = np.zeros(0, dtype=np.int64)
    while pending:
        cost = heapq.heappop(pending)
        chunks = levels.pop(cost)
        reached = np.concatenate([c[0] for c in chunks])
        _, first = np.unique(reached, return_index=True)
        first = np.sort(first)
        first = first[~_within(reached[first], settled)]
        if first.size == 0:
            continue
        reach = cost + cheapest_reading
        if reach > 0 and cap / reach <= bar():
            break  # nothing this far away or farther can tell more per unit of cost
        members = [np.concatenate([c[1][i] for c in chunks])[first] for i in range(len(places))]
        origin = np.concatenate([c[2] for c in chunks])[first]
        via = np.concatenate([np.full(len(c[0]), c[3]) for c in chunks])[first]
        ids = np.arange(len(parents), len(parents) + first.size)
        parents.extend(origin.tolist())
        moved.extend(via.tolist())
        settled = np.union1d(settled, reached[first])  # sorted
        for reading, tables in readings.items():
            rows = [
                np.stack(
                    [np.einsum("m,bmv->bv", sh, table[where]) for sh, where in zip(shares, members, strict=True)], 1
                )
                for table in tables
            ]
            evidence = _evidence(rows, weights)
            total = cost + float(costs[reading])
            values = np.minimum(evidence, cap) / total if total > 0 else np.full(first.size, math.inf)
            for b in np.argsort(-values, kind="stable").tolist():
                if not values[b] > bar() * (1 + 1e-9) + 1e-12:
                    break
                path = path_to(int(ids[b]))
                if reading in (here if not path else taken(path) if taken is not None else set()):
                    continue  # already read there
                macro = TellingMacro(path, reading, float(evidence[b]), total)
                heapq.heappush(found, (float(values[b]), -int(ids[b]), -reading, macro))
                if len(found) > count:
                    heapq.heappop(found)
        if settled.size >= max_nodes:
            continue
        # the actions already done where the nodes near the start lead (a move found blocked there)
        near = (
            [here if i == 0 else taken(path_to(i)) for i in ids.tolist()]
            if taken is not None and cost <= NEAR_COST
            else [here if i == 0 else set() for i in ids.tolist()]
        )
        for move in moves:
            after = [fstar[move][where] for where in members]
            ahead = np.stack([a[:, k] for a, k in zip(after, keys, strict=True)], axis=1)
            # two places merged: no reading tells them apart after it; the move found blocked there
            keep = (np.sort(ahead, axis=1)[:, 1:] != np.sort(ahead, axis=1)[:, :-1]).all(axis=1)
            keep &= np.array([move not in done for done in near], dtype=bool)
            key = key_of(after)
            keep &= ~_within(key, settled)
            if not keep.any():
                continue
            step = cost + float(costs[move])
            if step not in levels:
                levels[step] = []
                heapq.heappush(pending, step)
            levels[step].append((key[keep], tuple(a[keep] for a in after), ids[keep], move))
    return [macro for *_, macro in sorted(found, key=lambda item: (-item[0], -item[1], -item[2]))]


def _within(values: np.ndarray, ordered: np.ndarray) -> np.ndarray:
    """Which of ``values`` are in the sorted array ``ordered``."""
    at = np.minimum(np.searchsorted(ordered, values), max(ordered.size - 1, 0))
    out: np.ndarray = ordered[at] == values if ordered.size else np.zeros(values.shape, dtype=bool)
    return out


def _evidence(rows: Sequence[np.ndarray], weights: np.ndarray) -> np.ndarray:
    """:func:`which_place_evidence` for a batch: ``rows``, one ``(batch, n_places, n_values)`` array
    per part."""
    total = np.zeros(rows[0].shape[0]) if rows else np.zeros(0)
    for part in rows:
        mixture = np.einsum("p,bpv->bv", weights, part)
        for i, w in enumerate(weights.tolist()):
            if not 0.0 < w < 1.0:
                continue
            own = part[:, i]
            others = np.maximum((mixture - w * own) / (1.0 - w), 1e-12)
            with np.errstate(divide="ignore", invalid="ignore"):
                terms = np.where(own > 0, own * np.log(own / others), 0.0)
            total += w * terms.sum(axis=1)
    out: np.ndarray = np.maximum(total, 0.0)
    return out


MAX_PLACES = 2
"""The most look-alike places a telling macro leads together: a pair, as the paper's macros. (An
early version that led up to four -- tb3-sandbox's pillars make four-fold look-alikes -- took over
from the planner while it still made progress, and its cheap readings each nudged the belief.)"""


def few_places(places: Sequence[Place], goal: float, most: int = MAX_PLACES) -> list[Place] | None:
    """The fewest most likely of ``places`` (by mass) that hold ``goal`` of the belief between them,
    when that takes from 2 up to ``most`` places; None otherwise (one place holds the goal, or the
    belief is spread over more places than a macro leads together)."""
    ranked = sorted(places, key=lambda place: -float(place[1].sum()))[:most]
    held = 0.0
    for count, (_, mass) in enumerate(ranked, start=1):
        held += float(mass.sum())
        if held >= goal - 1e-12:
            return ranked if count >= 2 else None
    return None
