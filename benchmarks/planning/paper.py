"""The figures of Colledanchise et al. 2020 that the planning tables print beside ours, and the authors'
released code measured on a machine like ours."""

from __future__ import annotations

# The paper, by size 10^2, 10^3, 10^4 (None: "—", not run).
PAPER_SIZES = (100, 1_000, 10_000)
PAPER_PLAN_S: dict[str, tuple[float | None, ...]] = {
    "bestfirst": (0.0211, 0.7175, 6.6937),
    "uniform": (0.1424, 13.852, None),
}
PAPER_REPLANS: dict[str, tuple[float | None, ...]] = {"bestfirst": (2.58, 4.04, 9.72), "uniform": (2.02, 3.01, None)}
PAPER_COST: dict[str, tuple[float | None, ...]] = {
    "bestfirst": (29.37, 47.56, 61.09),
    "uniform": (24.91, 47.01, None),
    "random": (78.57, 97.05, 300.1),
}
PAPER_KTH_1E3 = (0.0557, 0.0161, 0.0088)
AUTHORS_CODE_HERE = (0.0023, 0.134, 9.65)
"""The authors' released code (-O3) measured on a machine like ours: mean plan time at 10^2..10^4."""


def paper_value(table: dict[str, tuple[float | None, ...]], strategy: str, states: int) -> float | None:
    """``table``'s figure for ``strategy`` at ``states``, or None where the paper has none."""
    if strategy not in table or states not in PAPER_SIZES:
        return None
    return table[strategy][PAPER_SIZES.index(states)]
