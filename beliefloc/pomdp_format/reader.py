"""Reading a ``.pomdp`` file into a :class:`~beliefloc.model.Model` (:func:`read_pomdp`,
:func:`parse_pomdp`): the statements are read into plain records
(:func:`~beliefloc.pomdp_format.parser.parse_statements`), then the model is built from them
(:func:`~beliefloc.pomdp_format.build.build_model`).

Supported forms (everything pomdp-solve's grammar accepts for a POMDP, except state-dependent
rewards):

* comments from ``#`` to the end of the line, anywhere; statements may span lines (a matrix's
  numbers, a long ``states:`` list) and ``:`` needs no surrounding spaces;
* the preamble ``discount: F``, ``values: reward|cost``, ``states:``, ``actions:``,
  ``observations:`` -- each a count (``states: 5``, elements then named ``0``..``4``) or a list of
  identifiers -- in any order, before the first ``T:``, ``O:`` or ``R:``; an element may always be
  referred to by its number as well as by its name;
* ``start: uniform``, ``start: p1 ... pn``, ``start: STATE``, ``start include: S...``,
  ``start exclude: S...`` (the start belief is only used by ``reset``; beliefloc's start is
  chosen on the command line);
* ``T: a : s : s' p``; ``T: a : s`` followed by a row of |S| probabilities, ``uniform`` or
  ``reset``; ``T: a`` followed by an |S| x |S| matrix, ``uniform`` or ``identity``;
* ``O: a : s' : o p``; ``O: a : s'`` followed by a row of |Omega| probabilities or ``uniform``;
  ``O: a`` followed by an |S| x |Omega| matrix, ``uniform`` or (when |Omega| = |S|) ``identity``;
* ``R: a : s : s' : o r``, ``R: a : s : s'`` + a row, ``R: a : s`` + a matrix, as long as the
  reward does not depend on the state or observation: every action's reward must end up one
  constant -- ``R: a : * : * : * -1.0``, possibly repeated by later entries, or the same value
  given for every pair of states (pomdp_py writes one ``R: a : s : s' : * r`` per pair) -- which
  becomes its cost ``-r`` (``+r`` with ``values: cost``); an action without ``R:`` costs 0. A
  state-dependent reward (the tiger's ``R: open-left : tiger-left ...``) is refused with a
  :class:`~beliefloc.errors.ModelError`, and so is a positive reward (a negative cost);
* ``*`` for any action, state or observation; a later entry overrides an earlier one, and an entry
  that is never given is 0; a whole matrix (``T: a`` + ...) replaces every earlier entry of it.

Every row of T and of O must sum to 1 (within ``1e-6``). An action whose T is the identity becomes a
perception action (``transition=None``), any other an actuation action -- unless a
``beliefloc-action`` comment says otherwise. An action's observation model is one
:class:`~beliefloc.model.ObservationPart` named after the action whose values are the
observations it gives a non-zero probability somewhere (in the order of ``observations:``, or the
comment's order), with one distinct row of the |S| x k table per group of states that observe
alike (``truth[j]`` picks state j's row, so ``matrix()`` is the file's table exactly); an action
whose only observation is ``none`` gets no parts at all. The observation ``nothing`` is the part's
silent value, so it is still typed ``nothing``. Every problem is a
:class:`~beliefloc.errors.ModelError` reading ``file:line: what is wrong``.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

from beliefloc.errors import ModelError
from beliefloc.model import Model, SourceInfo
from beliefloc.pomdp_format.build import build_model
from beliefloc.pomdp_format.parser import parse_statements
from beliefloc.source import read_text


def read_pomdp(path: str | Path) -> Model:
    """Read a Cassandra ``.pomdp`` file (see the module docs for the forms supported)."""
    path = Path(path)
    text, raw = read_text(path, ModelError)
    return parse_pomdp(text, path, source=SourceInfo(str(path), hashlib.sha256(raw).hexdigest()))


def parse_pomdp(text: str, path: str | Path = "<string>", *, source: SourceInfo | None = None) -> Model:
    """A model from the text of a ``.pomdp`` file; ``path`` is only used in messages and as the
    model's name when the file does not say it."""
    return build_model(parse_statements(text, str(path)), source)
