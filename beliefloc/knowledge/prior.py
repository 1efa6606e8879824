"""From counts of objects per room to a multinomial prior over rooms (Zhang et al. 2015, Sec. III-C1).

Pure functions: no clingo, no I/O. The inputs are what an answer set says (see
:meth:`beliefloc.knowledge.answer.AnswerSet.counts`): for each room k, the number ``a_{k,n}`` of
known objects of each primary class n located there, and the class tree.

Equations (numbering of the paper)::

    psi_n   = (ln(a_n) + xi) / prod_{h=1..H_n} W_h     if a_n > 0, else 0          (Eq. 2-3)
    alpha_k = sum_{n=1..N_k} psi_{n,k}                                           (Eq. 4)
    b_k     = alpha_k / alpha_0,   alpha_0 = sum_k alpha_k                         (Eq. 5)

Reading of Eq. 3 (the extracted text is ambiguous about heights): the primary class n is at height
h = 1, its parent at h = 2, ..., the lowest common ancestor (LCA) of n and the target class at
h = H_n. ``W_1 = 1`` ("the first postulate considers object instances"), and for h >= 2, ``W_h`` is
the number of child *classes* of the node at height h; the target's own class counts as a child.
This is the reading that reproduces the worked example exactly: pillow -> bedding -> object gives
H = 3, W = (1, 2, 4), psi = 1/8; computer -> computer_access (3 children: computer, fax, printer)
gives H = 2, W = (1, 3), psi = 1/3; three books -> book_magazine -> object gives
(ln 3 + 1)/(1*2*4) = 0.262; so alpha = [0.250, 1.141, 0.375] and b = [0.142, 0.646, 0.212].
A primary class that is the target class itself has H = 1 and psi = ln(a) + xi. A class in another
tree than the target (no common ancestor) gives no support.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

XI = 1.0
"""Fechner's constant xi of Eq. 2 (the paper uses 1)."""
DEFAULT_FLOOR = 0.01
"""Prior probability given to each room with no support at all (alpha_k = 0), so that the target is
never impossible in a room only because nothing is known about it; the supported rooms share the
rest in proportion to alpha. Ignored when no room has support (the prior is then uniform)."""


@dataclass(frozen=True)
class PsiTerm:
    """One term of Eq. 4: the support of ``count`` objects of ``primary`` class in ``room``."""

    room: str
    primary: str
    count: int
    lca: str
    path: tuple[str, ...]
    """The classes from the primary class (h = 1) up to the LCA (h = H)."""
    weights: tuple[int, ...]
    """W_1 .. W_H (W_1 = 1)."""
    psi: float

    @property
    def height(self) -> int:
        return len(self.path)

    def as_json(self) -> dict[str, Any]:
        """The term as plain JSON data: ``class`` is the primary class, ``height`` is H."""
        return {
            "room": self.room,
            "class": self.primary,
            "count": self.count,
            "lca": self.lca,
            "height": self.height,
            "weights": list(self.weights),
            "psi": self.psi,
        }


@dataclass(frozen=True)
class RoomPrior:
    """The prior over rooms for one target class, with its explanation."""

    target: str
    rooms: tuple[str, ...]
    alpha: dict[str, float]
    """Eq. 4 per room (0 for a room with no support)."""
    prior: dict[str, float]
    """Eq. 5, with the floor applied to rooms without support; sums to 1."""
    terms: tuple[PsiTerm, ...]
    floor: float
    floored: tuple[str, ...]
    """Rooms without support that got the floor."""
    uniform: bool
    """No room has support: the prior is uniform."""
    models: int = 1
    """Answer sets of the program (more than 1: counts from their cautious consequences)."""

    @property
    def message(self) -> str | None:
        """What a user should be told about how the prior was made, or None."""
        parts = []
        if self.uniform:
            parts.append(
                f"nothing in the knowledge base supports where a {self.target} is: the prior over the "
                f"{len(self.rooms)} rooms is uniform"
            )
        elif self.floored:
            parts.append(
                f"no support for a {self.target} in {', '.join(self.floored)}: "
                f"{'each gets' if len(self.floored) > 1 else 'it gets'} the floor {self.floor:g}"
            )
        if self.models > 1:
            parts.append(
                f"the knowledge base has {self.models} answer sets; the prior counts what holds in all of them "
                "(cautious consequences)"
            )
        return "; ".join(parts) or None

    def as_json(self) -> dict[str, Any]:
        """The prior as plain JSON data (the stable interface for scripts), with its psi terms."""
        return {
            "rooms": list(self.rooms),
            "alpha": self.alpha,
            "prior": self.prior,
            "target": self.target,
            "uniform": self.uniform,
            "floored": list(self.floored),
            "answer_sets": self.models,
            "terms": [term.as_json() for term in self.terms],
        }


def children(parents: Mapping[str, str]) -> dict[str, list[str]]:
    """Parent -> its child classes, in a deterministic order."""
    out: dict[str, list[str]] = {}
    for child, parent in sorted(parents.items()):
        out.setdefault(parent, []).append(child)
    return out


def ancestors(parents: Mapping[str, str], cls: str) -> list[str]:
    """``cls`` and its ancestors up to the root, in that order."""
    chain = [cls]
    seen = {cls: 0}
    while chain[-1] in parents:
        nxt = parents[chain[-1]]
        if nxt in seen:  # a cycle written in a .lp file (domain files are checked at load)
            raise ValueError(f"cycle in the class hierarchy: {' -> '.join([*chain[seen[nxt] :], nxt])}")
        seen[nxt] = len(chain)
        chain.append(nxt)
    return chain


def dilution_path(parents: Mapping[str, str], primary: str, target: str) -> tuple[str, ...] | None:
    """The classes from ``primary`` up to the LCA of ``primary`` and ``target`` (None: no LCA)."""
    up_target = set(ancestors(parents, target))
    path: list[str] = []
    for cls in ancestors(parents, primary):
        path.append(cls)
        if cls in up_target:
            return tuple(path)
    return None


def psi(count: int, weights: Sequence[int], xi: float = XI) -> float:
    """Eq. 3: ``(ln(count) + xi) / prod(weights)``, 0 when ``count`` is 0."""
    if count <= 0:
        return 0.0
    return (math.log(count) + xi) / math.prod(float(w) for w in weights)  # a deep, wide path: inf, so 0


def room_prior(
    rooms: Sequence[str],
    parents: Mapping[str, str],
    counts: Mapping[str, Mapping[str, int]],
    target: str,
    *,
    xi: float = XI,
    floor: float = DEFAULT_FLOOR,
    models: int = 1,
) -> RoomPrior:
    """Eq. 2-5 for every room; ``counts[room][primary_class] = a_{k,n}``.

    Returns new dicts; the inputs are not modified. ``floor`` must satisfy
    ``0 < floor`` and ``floor * len(rooms) < 1``.
    """
    if not rooms:
        raise ValueError("no rooms: a prior over rooms needs at least one")
    if not (floor > 0.0 and floor * len(rooms) < 1.0):  # NaN too
        raise ValueError(f"the floor must be above 0 and below 1/{len(rooms)} (1 / number of rooms), got {floor:g}")
    kids = children(parents)
    terms: list[PsiTerm] = []
    alpha: dict[str, float] = {}
    for room in rooms:
        total = 0.0
        for primary, count in sorted(counts.get(room, {}).items()):
            path = dilution_path(parents, primary, target)
            if path is None or count <= 0:
                continue
            weights = (1, *(len(kids.get(node, ())) for node in path[1:]))
            value = psi(count, weights, xi)
            terms.append(PsiTerm(room, primary, count, path[-1], path, weights, value))
            total += value
        alpha[room] = total
    alpha_0 = sum(alpha.values())
    if alpha_0 <= 0.0:
        prior = {room: 1.0 / len(rooms) for room in rooms}
        return RoomPrior(target, tuple(rooms), alpha, prior, tuple(terms), floor, (), True, models)
    floored = tuple(room for room in rooms if alpha[room] <= 0.0)
    share = 1.0 - floor * len(floored)
    prior = {room: (alpha[room] / alpha_0 * share if alpha[room] > 0.0 else floor) for room in rooms}
    return RoomPrior(target, tuple(rooms), alpha, prior, tuple(terms), floor, floored, False, models)
