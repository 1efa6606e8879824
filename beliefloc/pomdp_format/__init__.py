"""Cassandra's ``.pomdp`` text format: export a :class:`~beliefloc.model.Model`, read one back.

This is the format of pomdp-solve (A. R. Cassandra, "POMDP file format", pomdp.org), also read by
SARSOP/APPL, POMDPs.jl's POMDPFiles and pomdp_py. A localization model is a POMDP without rewards
(DESIGN.md): ``T[a][i, j] = P(s_j | s_i, a)``, ``O[a][j, o] = P(o | s_j, a)`` at the state reached,
and a cost ``gamma(a)`` becomes the reward ``-gamma(a)``.

Modules:

* :mod:`~beliefloc.pomdp_format.names` -- keywords, identifiers and numbers, shared by both directions;
* :mod:`~beliefloc.pomdp_format.writer` -- a model as ``.pomdp`` text (the layout written);
* :mod:`~beliefloc.pomdp_format.reader` -- :func:`read_pomdp` and :func:`parse_pomdp` (the forms read);
* :mod:`~beliefloc.pomdp_format.statements` -- the text into statements and beliefloc comments;
* :mod:`~beliefloc.pomdp_format.parser` -- the statements into plain records (a ``ParsedFile``),
  each kind read by :mod:`~beliefloc.pomdp_format.preamble` (the header),
  :mod:`~beliefloc.pomdp_format.tables` (``T:`` and ``O:``), :mod:`~beliefloc.pomdp_format.rewards`
  (``R:``) or :mod:`~beliefloc.pomdp_format.comments` (``# beliefloc-...``);
* :mod:`~beliefloc.pomdp_format.build` -- the records into a model, with the checked T and O of
  :mod:`~beliefloc.pomdp_format.matrices` and the costs of :mod:`~beliefloc.pomdp_format.costs`.
"""

from beliefloc.pomdp_format.names import FORMAT_VERSION, RESERVED, TOLERANCE, format_number, identifiers
from beliefloc.pomdp_format.reader import parse_pomdp, read_pomdp
from beliefloc.pomdp_format.writer import DISCOUNT, ExportSummary, pomdp_blocks, pomdp_text, write_pomdp

__all__ = [
    "DISCOUNT",
    "FORMAT_VERSION",
    "RESERVED",
    "TOLERANCE",
    "ExportSummary",
    "format_number",
    "identifiers",
    "parse_pomdp",
    "pomdp_blocks",
    "pomdp_text",
    "read_pomdp",
    "write_pomdp",
]
