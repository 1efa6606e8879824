"""Types of the compiled traversal in ``_raycast.c`` (see its header)."""

from typing import Any

def walk(
    blocked: Any,
    clearance: Any,
    u0: Any,
    v0: Any,
    du: Any,
    dv: Any,
    delta_c: Any,
    delta_r: Any,
    limit: Any,
    step_c: Any,
    step_r: Any,
    edge_c: Any,
    edge_r: Any,
    col: Any,
    row: Any,
    next_c: Any,
    next_r: Any,
    t: Any,
    result: Any,
    walking: Any,
    /,
) -> None: ...
