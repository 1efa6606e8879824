"""The edge to the file system: hand-written YAML/JSON input files, validated with pydantic, with errors
that point at the line; the limits on what they may ask for; the one way outputs are written.

The one way every input file (maps, belief files, domains) is read:

1. :func:`read_text` (:mod:`.files`) refuses anything that is not a regular file of a sane size before reading it.
2. :func:`read_source` (:mod:`.yaml12`) reads the YAML (JSON is YAML) from the parser's events, without recursion,
   into plain Python data under the YAML 1.2 core schema (``on``, ``yes``, ``1:30`` and
   ``2001-12-14`` are text; ``010`` is ten), remembering where (line, column) each value and key was
   written, keyed by its path from the root. Nesting deeper than :data:`~beliefloc.source.limits.NESTING`
   and more values than :data:`~beliefloc.source.limits.YAML_NODES` (counting every use of an alias in
   full) are refused before they are built.
3. :func:`validate_source` (:mod:`.validation`) runs a pydantic model over the data. A pydantic error's ``loc`` or a
   :class:`~beliefloc.errors.FieldError`'s ``path`` is mapped back to the line, so a message reads
   ``maps/kitchen.yaml:14:5: sensors.look.false_positive: should be less than or equal to 1, got 1.5``.

:class:`Source` (:mod:`.located`) is the parsed file: its data and the marks of every key and value.
:mod:`.limits` holds the bounds every reader of an outside file enforces (each raisable by an environment
variable), :mod:`.file_kinds` tells the kinds of beliefloc file apart ("X is a domain, not a map"), and
:mod:`.atomic_write` is the one way every output is written: a temporary file renamed into place.
Beside them, the little machinery every part may share: :func:`.located.gc_paused` (the cycle collector
paused while many small objects are built), :mod:`.threads` (one pool of threads a process, for
passes that release the interpreter's lock) and :mod:`.sparse_kernels` (SciPy's sparse products with an
output vector of our own).
"""

from beliefloc.source.files import not_regular_file, read_text
from beliefloc.source.located import Source, format_path
from beliefloc.source.validation import refuse_field_name, validate_source
from beliefloc.source.yaml12 import parse_source, read_source, resolve_plain

__all__ = [
    "Source",
    "format_path",
    "not_regular_file",
    "parse_source",
    "read_source",
    "read_text",
    "refuse_field_name",
    "resolve_plain",
    "validate_source",
]
