"""The search space of a domain: on its map when it has ``map:``, else on its plane of rooms.

The one place that chooses between the two builders, so that neither space module imports the
other (:mod:`beliefloc.object_search.space`, :mod:`beliefloc.object_search.map_space`).
"""

from __future__ import annotations

from beliefloc.knowledge.domain import Domain
from beliefloc.object_search.map_space import map_search_space
from beliefloc.object_search.space import SearchSpace, plane_search_space


def search_space(domain: Domain) -> SearchSpace:
    """Build the search space of a validated domain: on its map when it has ``map:``
    (:func:`~beliefloc.object_search.map_space.map_search_space`), else on its plane of rooms
    (:func:`~beliefloc.object_search.space.plane_search_space`). :class:`~beliefloc.errors.DomainError`
    when the domain cannot be searched (no ``search:`` section, the robot starts in a room it cannot
    enter, a room it cannot reach)."""
    if domain.map is not None:
        return map_search_space(domain)
    return plane_search_space(domain)
