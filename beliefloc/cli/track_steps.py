"""``track --json`` over a log of steps: the document :func:`~beliefloc.cli.common.print_json` would
print, built a chunk of steps at a time (a log of a million steps is 1.6 GB of JSON, never held)."""

from __future__ import annotations

import json
import sys
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import numpy as np

    from beliefloc.model import Model
    from beliefloc.robots.tracking import StepLog


def print_json_steps(model: Model, belief: np.ndarray, log: StepLog) -> None:
    """What ``track --json`` prints, as :func:`print_json` would print it, written to a temporary
    file a chunk of steps at a time, then copied to stdout: a step whose observation is impossible
    leaves no half document on stdout."""
    import shutil
    import tempfile

    import numpy as np

    from beliefloc.belief import by_state_name
    from beliefloc.pose import pose_json
    from beliefloc.robots.tracking import track_chunks

    dumps = json.dumps
    # each distinct step's entry as json.dumps(..., indent=2) writes it inside the document, with a
    # %s for its probability (%.0s: none, "null" written) and for each state's probability
    belief_slots = ",\n".join(f"        {dumps(name).replace('%', '%%')}: %s" for name in model.states.names)
    templates = []
    for step in log.steps:
        fields = (
            f'    {{\n      "step": {dumps(step.text)},\n      "action": {dumps(step.action.name)},\n'
            f'      "observation": {dumps(step.observation)},\n'
        ).replace("%", "%%")
        probability = '      "probability": %s,\n' if step.index is not None else '      "probability": null%.0s,\n'
        templates.append(fields + probability + '      "belief": {\n' + belief_slots + "\n      }\n    }")
    n = model.n_states
    final = belief
    with tempfile.TemporaryFile("w+b") as spool:
        spool.write(b'{\n  "steps": [')
        for chunk in track_chunks(model, belief, log):
            if not np.isfinite(chunk.beliefs).all():
                bad = int(np.flatnonzero(~np.isfinite(chunk.beliefs).all(axis=1))[0])
                raise AssertionError(
                    f"step {chunk.start + bad + 1}: the belief holds a value that is not a finite number"
                )
            values = np.empty((len(chunk.codes), n + 1))
            values[:, 0] = chunk.probabilities
            values[:, 1:] = chunk.beliefs
            shown = float_reprs(values)
            width = n + 1
            parts = []
            for k, code in enumerate(chunk.codes.tolist()):
                parts.append(templates[code] % tuple(shown[k * width : (k + 1) * width]))
            spool.write((("\n" if chunk.start == 0 else ",\n") + ",\n".join(parts)).encode("utf-8"))
            final = chunk.beliefs[-1]
        belief_text = _indented(by_state_name(model, final), 2).lstrip()
        tail = f'\n  ],\n  "belief": {belief_text},\n  "pose": {_indented(pose_json(model, final), 2).lstrip()}\n}}\n'
        spool.write(tail.encode("utf-8"))
        spool.seek(0)
        sys.stdout.flush()
        stdout = getattr(sys.stdout, "buffer", None)
        if stdout is not None:
            shutil.copyfileobj(spool, stdout, 1 << 20)
            stdout.flush()
        else:  # a text stream without bytes under it (a test's capture)
            while block := spool.read(1 << 20):
                sys.stdout.write(block.decode("utf-8"))


_CHECKED_EVERY = 97
""":func:`float_reprs` compares one value in this many with ``float.__repr__``."""


def float_reprs(values: np.ndarray) -> list[str]:
    """Each of ``values`` (finite floats, any shape, in C order) as ``json.dumps`` writes it: Python's
    shortest ``repr``.

    ``float.__repr__`` costs about 0.3 µs a value, and a million-step log of 36 states holds 37
    million; ujson's double-conversion finds the same shortest digits in a fifth of the time and
    writes them the same way but for one-digit exponents (``1e-5`` for ``1e-05``), which are padded
    here in one pass over the bytes. A sample of the values is compared with ``repr``: on any
    difference (an ujson that writes otherwise), all of them are written by ``repr``."""
    import numpy as np

    flat = values.ravel().tolist()
    try:
        import ujson
    except ImportError:  # pragma: no cover - ujson is a dependency; json's encoder is the reference
        return json.dumps(flat)[1:-1].split(", ")
    raw = np.frombuffer(ujson.dumps(flat).encode("ascii"), dtype=np.uint8)
    # a '-' two characters before a ',' or the closing ']' is a one-digit exponent's: e-5, -> e-05,
    minus = np.flatnonzero(raw[:-2] == ord("-"))
    single = minus[(raw[minus + 2] == ord(",")) | (raw[minus + 2] == ord("]"))]
    if len(single):
        raw = np.insert(raw, single + 1, ord("0"))
    shown = raw[1:-1].tobytes().decode("ascii").split(",")
    sample = range(0, len(flat), _CHECKED_EVERY) if len(shown) == len(flat) else ()
    if len(shown) != len(flat) or any(shown[i] != float.__repr__(flat[i]) for i in sample):
        return json.dumps(flat)[1:-1].split(", ")
    return shown


def _indented(value: object, spaces: int) -> str:
    """``value`` as :func:`print_json` writes it inside a document, ``spaces`` deep."""
    pad = " " * spaces
    return "\n".join(pad + line for line in json.dumps(value, indent=2, allow_nan=False).splitlines())
