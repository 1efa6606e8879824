"""Types of LAO*'s compiled bookkeeping in ``_lao.c`` (see its header: contingent.py's loops, the same numbers)."""

from collections.abc import Callable
from typing import Any

def setup(node_class: type, frontier: Any, /) -> None: ...
def revise(
    node: Any,
    costs: list[float],
    dead_ends: Callable[[], list[Any]],
    max_revisions: int,
    trap_check: int,
    same: float,
    /,
) -> dict[Any, int]: ...
def flow(
    pending: dict[Any, float], reached: list[Any], max_flow: int, settled: float, cancelled: float, same: float, /
) -> list[Any] | None: ...
def reroute(changed: dict[Any, int], /) -> dict[Any, float]: ...
