"""``track --json`` over a log of steps: the document :func:`~beliefloc.cli.common.print_json` would
print, built a chunk of steps at a time (a log of a million steps is 1.6 GB of JSON, never held)."""

from __future__ import annotations

import errno
import json
import os
import sys
from typing import TYPE_CHECKING, BinaryIO

if TYPE_CHECKING:
    import numpy as np

    from beliefloc.model import Model
    from beliefloc.robots.tracking import StepLog


def print_json_steps(model: Model, belief: np.ndarray, log: StepLog) -> None:
    """What ``track --json`` prints, as :func:`print_json` would print it, written to a temporary
    file a chunk of steps at a time, then copied to stdout: a step whose observation is impossible
    leaves no half document on stdout."""
    import tempfile

    import numpy as np

    from beliefloc.belief import by_state_name
    from beliefloc.pose import pose_json
    from beliefloc.robots.tracking import track_chunks

    dumps = json.dumps
    n = model.n_states
    # a step's entry as json.dumps(..., indent=2) writes it inside the document: text between values
    # (each state's key once, each distinct step's fields once) around its probability and beliefs
    heads = np.array(
        [
            f'    {{\n      "step": {dumps(step.text)},\n      "action": {dumps(step.action.name)},\n'
            f'      "observation": {dumps(step.observation)},\n'
            f'      "probability": {"" if step.index is not None else "null"}'
            for step in log.steps
        ],
        dtype=object,
    )
    unobserved = np.array([step.index is None for step in log.steps])
    keys = [dumps(name) for name in model.states.names]
    between = np.array(
        [
            "",
            f',\n      "belief": {{\n        {keys[0]}: ',
            *(f",\n        {key}: " for key in keys[1:]),
            "\n      }\n    }",
        ],
        dtype=object,
    )  # then the step's values: its probability (or nothing), each state's, ",\n" before the next step
    final = belief
    with tempfile.TemporaryFile("w+b") as spool:
        spool.write(b'{\n  "steps": [\n')
        for chunk in track_chunks(model, belief, log):
            k = len(chunk.codes)
            if not np.isfinite(chunk.beliefs).all():
                bad = int(np.flatnonzero(~np.isfinite(chunk.beliefs).all(axis=1))[0])
                raise AssertionError(
                    f"step {chunk.start + bad + 1}: the belief holds a value that is not a finite number"
                )
            values = np.empty((k, n + 1))
            values[:, 0] = chunk.probabilities
            values[:, 1:] = chunk.beliefs
            text = np.empty((k, 2 * n + 4), dtype=object)
            text[:, 0::2] = between
            text[:, 0] = heads[chunk.codes]
            text[:, 1 : 2 * n + 2 : 2] = np.array(float_reprs(values), dtype=object).reshape(k, n + 1)
            text[unobserved[chunk.codes], 1] = ""
            text[:, -1] = ",\n"
            if chunk.start + k == len(log):
                text[-1, -1] = "\n"
            spool.write("".join(text.ravel().tolist()).encode("utf-8"))
            final = chunk.beliefs[-1]
        belief_text = _indented(by_state_name(model, final), 2).lstrip()
        tail = f'  ],\n  "belief": {belief_text},\n  "pose": {_indented(pose_json(model, final), 2).lstrip()}\n}}\n'
        spool.write(tail.encode("utf-8"))
        _copy_to_stdout(spool)


def _copy_to_stdout(spool: BinaryIO) -> None:
    """The whole of ``spool`` to stdout: by the kernel (``sendfile``) when stdout is a file or a pipe,
    1.6 GB not copied twice through Python, else a block at a time."""
    import shutil

    size = spool.seek(0, os.SEEK_END)
    spool.seek(0)
    sys.stdout.flush()
    stdout = getattr(sys.stdout, "buffer", None)
    if stdout is None:  # a text stream without bytes under it (a test's capture)
        while block := spool.read(1 << 20):
            sys.stdout.write(block.decode("utf-8"))
        return
    stdout.flush()
    try:
        target = stdout.fileno()
    except (OSError, ValueError):  # io.UnsupportedOperation is both: a stream without a descriptor
        target = -1
    sent = 0
    if target >= 0 and hasattr(os, "sendfile"):
        try:
            while sent < size:
                done = os.sendfile(target, spool.fileno(), sent, size - sent)
                if done == 0:
                    break
                sent += done
        except OSError as exc:
            if sent or exc.errno not in (errno.EINVAL, errno.ENOSYS, errno.EOPNOTSUPP, errno.ENOTSOCK):
                raise
    spool.seek(sent)
    shutil.copyfileobj(spool, stdout, 1 << 20)
    stdout.flush()


_CHECKED_EVERY = 499
""":func:`float_reprs` compares one value in this many with ``float.__repr__``."""


def float_reprs(values: np.ndarray) -> list[str]:
    """Each of ``values`` (finite floats, any shape, in C order) as ``json.dumps`` writes it: Python's
    shortest ``repr``.

    ``float.__repr__`` costs about 0.3 µs a value, and a million-step log of 36 states holds 37
    million: :func:`_ujson_reprs` finds the same digits in a fifth of the time. One value in
    :data:`_CHECKED_EVERY` is compared with ``repr``; on any difference (an ujson that writes
    otherwise), all of them are written by ``repr``."""
    flat = values.ravel().tolist()
    try:
        shown = _ujson_reprs(flat)
    except ImportError:  # pragma: no cover - ujson is a dependency; json's encoder is the reference
        shown = []
    if len(shown) != len(flat) or any(shown[i] != float.__repr__(flat[i]) for i in range(0, len(flat), _CHECKED_EVERY)):
        return json.dumps(flat)[1:-1].split(", ")
    return shown


def _ujson_reprs(flat: list[float]) -> list[str]:
    """ujson's double-conversion writes the shortest digits that read back as the float, as ``repr``
    does, and in the same form but for one-digit exponents (``1e-5`` for ``1e-05``), padded here in
    one pass over the bytes."""
    import numpy as np
    import ujson

    raw = np.frombuffer(ujson.dumps(flat).encode("ascii"), dtype=np.uint8)
    # a '-' two characters before a ',' or the closing ']' is a one-digit exponent's: e-5, -> e-05,
    minus = np.flatnonzero(raw[:-2] == ord("-"))
    single = minus[(raw[minus + 2] == ord(",")) | (raw[minus + 2] == ord("]"))]
    if len(single):
        raw = np.insert(raw, single + 1, ord("0"))
    return raw[1:-1].tobytes().decode("ascii").split(",")


def _indented(value: object, spaces: int) -> str:
    """``value`` as :func:`print_json` writes it inside a document, ``spaces`` deep."""
    pad = " " * spaces
    return "\n".join(pad + line for line in json.dumps(value, indent=2, allow_nan=False).splitlines())
