"""``summarize``: the statistics of a results file (``simulate --out``, ``search simulate --out``),
while its run goes on or after it ended."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer
from rich.markup import escape

from beliefloc.cli.common import boundary, escape_controls, print_json
from beliefloc.cli.options import JsonOption
from beliefloc.errors import UsageError
from beliefloc.render import stderr_console, stdout_console

if TYPE_CHECKING:
    from rich.console import RenderableType

    from beliefloc.files.results_file import ResultsScan


@boundary
def summarize(
    results_file: Annotated[
        Path,
        typer.Argument(
            metavar="FILE.jsonl",
            help="A results file written by 'simulate --out' or 'search simulate --out'.",
            show_default=False,
        ),
    ],
    json_output: JsonOption = False,
) -> None:
    """Print the summary table of a results file: the same table (and with --json the same
    "summary") as the run that wrote it prints at its end.

    A file still being written is read up to its last whole line; the units not yet in it are
    said on stderr (with --json: "done" of "total").

    Examples:

    \b
      beliefloc simulate maps/kitchen.yaml -n 20 --out kitchen.jsonl && beliefloc summarize kitchen.jsonl
      beliefloc search simulate domains/home.yaml -n 10 --out home.jsonl && beliefloc summarize home.jsonl --json
    """
    from beliefloc.files.results_file import ResultsFileError, scan_results

    if results_file.is_dir():
        raise UsageError(f"{results_file}: is a folder; name a results file (FILE.jsonl)")
    if not results_file.is_file():
        raise UsageError(f"{results_file}: no such file")
    scan = scan_results(results_file)
    command = str(scan.header["command"])
    if command not in _SUMMARIES:
        shown = escape_controls(command)[:60]
        raise UsageError(f"{results_file}: written by '{shown}', which this beliefloc cannot summarize")
    try:  # one pass over the lines, each checked as it is read (the file is never held whole)
        summary, table = _SUMMARIES[command](scan)
    except (KeyError, TypeError, ValueError, AttributeError) as exc:
        raise ResultsFileError(
            f"{results_file}: its header or a line lacks what a '{command}' results file holds ({exc!r})"
        ) from None
    done, total = scan.count, scan.total
    if done < total:
        stderr_console().print(
            escape(f"{results_file}: {done} of {total} {scan.unit}s so far"), soft_wrap=True, highlight=False
        )
    if json_output:
        print_json(
            {
                "file": str(results_file),
                "command": command,
                "unit": scan.unit,
                "done": done,
                "total": total,
                "summary": summary,
            }
        )
        return
    stdout_console().print(table)


def _simulate(scan: ResultsScan) -> tuple[dict[str, Any], RenderableType]:
    from beliefloc.files.results_file import decoded_lines
    from beliefloc.render.plan import summary_table
    from beliefloc.simulation.episode import records_of_result
    from beliefloc.simulation.episode import summarize as summarize_episodes

    settings = scan.header["settings"]
    timings, threshold = bool(settings["timings"]), float(settings["threshold"])
    lines = decoded_lines(scan.path, "simulate", scan.lines(), lambda line: list(records_of_result(line)))
    summary = summarize_episodes(record for records in lines for record in records)
    as_json = {name: s.as_json(timings=timings) for name, s in summary.items()}
    return as_json, summary_table(summary, threshold)


def _search(scan: ResultsScan) -> tuple[dict[str, Any], RenderableType]:
    from beliefloc.files.results_file import decoded_lines
    from beliefloc.object_search.experiment import TrialRecord, run_title
    from beliefloc.object_search.experiment import summarize as summarize_trials
    from beliefloc.render.search import trials_table

    settings = scan.header["settings"]
    timings = bool(settings["timings"])
    title = run_title(str(settings["domain_name"]), scan.total, int(settings["seed"]), settings["trial_settings"])
    summary = summarize_trials(decoded_lines(scan.path, "search simulate", scan.lines(), TrialRecord.from_json))
    as_json = {arm: s.as_json(timings=timings) for arm, s in summary.items()}
    return as_json, trials_table(summary, escape(title))


_SUMMARIES = {"simulate": _simulate, "search simulate": _search}
"""How each command's results are summed up, by the header's ``command``."""


def register(app: typer.Typer) -> None:
    app.command(short_help="Print the summary of a results file (--out).")(summarize)
