"""Print beliefloc's import graph: which part of the package imports which, and any cycle.

Run from the project root::

    python tools/import_graph.py            # edges between parts (subpackages and top-level modules)
    python tools/import_graph.py --modules  # edges between modules

Every ``import`` counts, wherever it stands (module level, inside a function, under
``TYPE_CHECKING``): a lazy import is still a dependency a reader must know about. Edges that only
exist under ``TYPE_CHECKING`` are marked ``(types)``, edges made only inside functions (loaded when
the function first runs) ``(lazy)``. A cycle between modules is listed at the end with the exit
code 1, so the script can guard the layering in a test.
"""

from __future__ import annotations

import argparse
import ast
import sys
from collections import defaultdict
from pathlib import Path

PACKAGE = "beliefloc"


def module_name(path: Path, root: Path) -> str:
    parts = list(path.relative_to(root).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _lines(node: ast.stmt) -> range:
    return range(node.lineno, (node.end_lineno or node.lineno) + 1)


def _type_checking_lines(tree: ast.Module) -> set[int]:
    """The lines under ``if TYPE_CHECKING:``."""
    return {
        line
        for node in ast.walk(tree)
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test)
        for line in _lines(node)
    }


def _function_lines(tree: ast.Module) -> set[int]:
    """The lines inside function bodies: what they import is loaded when the function first runs."""
    return {
        line
        for node in ast.walk(tree)
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef))
        for line in _lines(node)
    }


TYPES, LAZY, EAGER = "types", "lazy", ""


def imports_of(path: Path, name: str, known: set[str]) -> dict[str, str]:
    """The package modules ``name`` imports, each with how: ``types`` (only under TYPE_CHECKING),
    ``lazy`` (only inside functions) or eager (at module level)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    typing_only = _type_checking_lines(tree)
    in_functions = _function_lines(tree)
    is_package = path.name == "__init__.py"
    found: dict[str, str] = {}
    for node in ast.walk(tree):
        targets: list[str] = []
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = name.split(".") if is_package else name.split(".")[:-1]
                anchor = anchor[: len(anchor) - node.level + 1]
                base = ".".join([*anchor, base] if base else anchor)
            # "from package import module" names a module; "from module import thing" does not
            targets = [f"{base}.{alias.name}" if f"{base}.{alias.name}" in known else base for alias in node.names]
        for target in targets:
            while target and target not in known:
                target = target.rpartition(".")[0]
            if target and target != name and target.startswith(PACKAGE):
                how = TYPES if node.lineno in typing_only else LAZY if node.lineno in in_functions else EAGER
                found[target] = _strongest(found.get(target, TYPES), how)
    return found


def _strongest(a: str, b: str) -> str:
    """Of two ways one module imports another, the one that loads it soonest."""
    order = (EAGER, LAZY, TYPES)
    return min(a, b, key=order.index)


def part(module: str) -> str:
    """``beliefloc.cli.search`` -> ``cli``; ``beliefloc.model`` -> ``model``."""
    pieces = module.split(".")
    return pieces[1] if len(pieces) > 1 else pieces[0]


def find_cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    components: list[list[str]] = []
    counter = 0
    for start in sorted(graph):
        if start in index:
            continue
        work = [(start, iter(sorted(graph[start])))]
        index[start] = low[start] = counter
        counter += 1
        stack.append(start)
        on_stack.add(start)
        while work:
            node, children = work[-1]
            advanced = False
            for child in children:
                if child not in index:
                    index[child] = low[child] = counter
                    counter += 1
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph.get(child, ())))))
                    advanced = True
                    break
                if child in on_stack:
                    low[node] = min(low[node], index[child])
            if advanced:
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == node:
                        break
                if len(component) > 1:
                    components.append(sorted(component))
    return components


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--modules", action="store_true", help="edges between modules, not parts")
    parser.add_argument("--root", type=Path, default=Path(__file__).resolve().parent.parent)
    args = parser.parse_args(argv)
    files = {module_name(p, args.root): p for p in sorted((args.root / PACKAGE).rglob("*.py"))}
    known = set(files)
    graph: dict[str, set[str]] = {}
    edges: dict[tuple[str, str], str] = {}
    for name, path in files.items():
        found = imports_of(path, name, known)
        # a package's own __init__ re-exports are not a dependency of the package on itself
        graph[name] = {t for t in found if not (name and t.startswith(name + "."))}
        for target, how in found.items():
            key = (name, target) if args.modules else (part(name), part(target))
            if key[0] != key[1]:
                edges[key] = _strongest(edges.get(key, TYPES), how)
    by_source: dict[str, list[str]] = defaultdict(list)
    for (source, target), how in sorted(edges.items()):
        by_source[source].append(target + (f" ({how})" if how else ""))
    for source in sorted(by_source):
        print(f"{source} -> {', '.join(by_source[source])}")
    cycles = find_cycles(graph)
    for cycle in cycles:
        print(f"cycle: {' <-> '.join(cycle)}")
    if not cycles:
        print("no cycle between modules")
    return 1 if cycles else 0


if __name__ == "__main__":
    sys.exit(main())
