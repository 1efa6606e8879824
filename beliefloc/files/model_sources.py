"""Where a model comes from: a map, a compiled model file, or a Cassandra ``.pomdp`` file.

:func:`open_model` reads any of the three by its suffix; :func:`source_map` goes back from a model
to the map it was compiled from (its rooms, its layout), checking that the map has not changed.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from beliefloc.errors import InvalidValueError, ModelError

if TYPE_CHECKING:
    from beliefloc.model import Model
    from beliefloc.semantic_map import SemanticMap

MAP_SUFFIXES = (".yaml", ".yml")
POMDP_SUFFIX = ".pomdp"
MODEL_SUFFIX = ".npz"


def open_model(path: Path, *, on_warning: Callable[[str], None] | None = None) -> Model:
    """A model from a map (``.yaml``), a compiled model (``.npz``) or a Cassandra ``.pomdp`` file;
    what reading a map has to say goes to ``on_warning``, and so does a compiled model whose map
    is gone (it cannot be checked for staleness)."""
    suffix = path.suffix.lower()
    if suffix in MAP_SUFFIXES:
        from beliefloc.semantic_map import compile_model, load_map

        return compile_model(load_map(path, on_warning=on_warning))
    if suffix == MODEL_SUFFIX:
        from beliefloc.files.model_file import load_model

        return load_model(path, on_warning=on_warning)
    if suffix == POMDP_SUFFIX:
        from beliefloc.pomdp_format import read_pomdp

        return read_pomdp(path)
    raise InvalidValueError(
        f"{path}: unknown kind of file; expected a map (.yaml), a model built by 'beliefloc build' "
        f"(.npz) or a Cassandra POMDP file (.pomdp)"
    )


def source_map(model: Model) -> SemanticMap:
    """The map ``model`` was compiled from, read again and checked to be the very same file.

    Raises :class:`ModelError` for a model without a map (a .pomdp import) or whose map cannot be
    read or has changed since the model was built."""
    from beliefloc.semantic_map import load_map

    source = model.source
    if source is None or model.grid is None:
        raise ModelError(f"model {model.name!r} was not compiled from a map (an imported .pomdp?), so it has no rooms")
    if not Path(source.path).is_file():
        raise ModelError(
            f"model {model.name!r} was compiled from {source.path}, which is not there any more; use the map itself"
        )
    smap = load_map(source.path)
    if smap.source is None or smap.source.sha256 != source.sha256:
        raise ModelError(f"{source.path} has changed since model {model.name!r} was built from it; rebuild the model")
    return smap
