"""Plans, search statistics and experiment summaries as rich tables."""

from __future__ import annotations

from typing import TYPE_CHECKING

from rich import box
from rich.markup import escape
from rich.table import Table
from rich.tree import Tree

if TYPE_CHECKING:
    from beliefloc.model import Model
    from beliefloc.planning.best_first import PlanResult
    from beliefloc.planning.contingent import PolicyNode, PolicyResult
    from beliefloc.simulation.episode import StrategySummary


def plan_table(result: PlanResult, title: str) -> Table:
    table = Table(title=title, title_justify="left")
    table.add_column("step", justify="right")
    table.add_column("action")
    table.add_column("expected observation")
    table.add_column("p(o|a,b)", justify="right")
    table.add_column("max belief", justify="right")
    table.add_column("cost", justify="right")
    for i, step in enumerate(result.steps, start=1):
        table.add_row(
            str(i),
            step.action,
            step.observation if step.observation is not None else "-",
            f"{step.probability:.3f}" if step.observation is not None else "-",
            f"{step.max_belief:.3f}",
            f"{step.cost:g}",
        )
    if result.partial:
        table.caption = (
            "incomplete: the budget ran out; the best partial plan by its estimate (a robot does its first step)"
        )
        table.caption_justify = "left"
    return table


def path_line(result: PlanResult, floor: float) -> str:
    """The shown path's probability (that the robot sees each of its expected observations), flagged
    below ``floor``."""
    seen = sum(step.observation is not None for step in result.steps)
    line = (
        f"path probability {result.path_probability:.3g}: the robot sees the {seen} expected "
        f"observation{'' if seen == 1 else 's'} above together with this probability"
    )
    if result.path_probability < floor:
        line += (
            f"\n[bold]unlikely path[/] (below {floor:g}): the robot will most likely see something else and "
            "plan again; the cost shown is not what localizing is expected to cost (plan --policy estimates that)"
        )
    return line


def effort_line(result: PlanResult) -> str:
    return (
        f"{result.status.value}: {result.expanded} beliefs expanded, {result.generated} generated, "
        f"{result.seconds:.3f} s"
    )


def summary_table(summary: dict[str, StrategySummary], threshold: float) -> Table:
    """Per strategy: episodes, localized, correct, mean plan time, replans, cost ± sd, steps, failures."""
    runs = max((s.episodes for s in summary.values()), default=0)
    table = Table(
        title=f"{runs} episode{'' if runs == 1 else 's'} per strategy (localized: max belief >= {threshold:g}; "
        "correct: localized at the true state)",
        title_justify="left",
        box=box.SIMPLE_HEAD,
        pad_edge=False,
        padding=(0, 1),
    )
    for column in ("strategy", "localized", "correct", "plan s", "replans", "cost", "steps"):
        table.add_column(column, justify="left" if column == "strategy" else "right", no_wrap=True)
    for name, s in summary.items():
        table.add_row(
            escape(str(name)),  # from a results file: never markup
            str(s.localized),
            str(s.correct),
            _num(s.mean_plan_seconds, "{:.4f}"),
            _num(s.mean_replans, "{:.2f}"),
            _pm(s.mean_cost, s.stdev_cost, "{:.1f}"),  # mean ± sd
            _num(s.mean_steps, "{:.1f}"),
        )
    # failures go under the table (rarely any, and long words): the columns then fit 80 characters
    failures = [
        f"{name}: " + ", ".join(f"{count} {status}" for status, count in s.failures.items())
        for name, s in summary.items()
        if s.failures
    ]
    table.caption = escape("not localized: " + "; ".join(failures)) if failures else "every episode localized"
    table.caption_justify = "left"
    return table


def _num(value: float | None, fmt: str) -> str:
    return "-" if value is None else fmt.format(value)


def _pm(mean: float | None, spread: float | None, fmt: str) -> str:
    if mean is None:
        return "-"
    return fmt.format(mean) + ("" if spread is None else "±" + fmt.format(spread))


def policy_tree(result: PolicyResult, model: Model, title: str, depth: int) -> Tree:
    """The first ``depth`` levels of a contingent policy as a rich tree: each node's action, expected
    cost and max belief, each branch's observation and probability, leaves by kind (the pruned and
    dead-end leaves of a node on one line), and branches back to a belief above as such."""
    from beliefloc.planning.contingent import LeafKind

    tree = Tree(title)

    def label(node: PolicyNode) -> str:
        where = f"max {node.max_belief:.3f} at {model.states.name(node.most_likely)}"
        if node.action is None:
            kind = node.leaf.value if node.leaf is not None else "leaf"
            return f"[bold]{kind}[/] ({where}; expected cost {node.expected_cost:.2f})"
        return f"[bold]{escape(node.action)}[/] (expected cost {node.expected_cost:.2f}; {where})"

    def grow(branch: Tree, node: PolicyNode, level: int, path: dict[int, int]) -> None:
        if node.action is None:
            return
        if level >= depth:
            branch.add(f"… {node.size() - 1} more nodes below")
            return
        path = {**path, node.number: level}
        replan = [c for c in node.branches if c.node.leaf in (LeafKind.PRUNED, LeafKind.LOOP)]
        for child in node.branches:
            if child in replan:
                continue
            seen = "" if child.observation is None else f"{escape(child.observation)}, "
            if child.node.number in path:  # a loop: the belief of a node above, carried on from there
                up = level + 1 - path[child.node.number]
                where = "this belief again" if up == 1 else f"the belief {up} levels up again"
                branch.add(f"{seen}p = {child.probability:.3f}: {where} (expected cost {child.node.expected_cost:.2f})")
                continue
            grow(branch.add(f"{seen}p = {child.probability:.3f}: {label(child.node)}"), child.node, level + 1, path)
        if replan:
            total = sum(c.probability for c in replan)
            branch.add(f"[dim]{len(replan)} unlikely or uninformative observations, p = {total:.3f}: plan again[/]")

    grow(tree.add(label(result.root)), result.root, 0, {})
    return tree


def policy_line(result: PolicyResult) -> str:
    """The policy's expected cost and the search's effort."""
    return (
        f"{result.status.value}: expected cost {result.expected_cost:.2f}, {result.nodes()} policy nodes; "
        f"{result.expanded} beliefs expanded, {result.generated} generated, {result.seconds:.3f} s"
    )
