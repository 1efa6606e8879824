"""The vectorised compile kernels against plain one-at-a-time references (the code they replaced).

``viewing_angles_many`` does every landmark at once and ``_annotated_states`` every annotated
state at once; both must give exactly what the per-landmark and per-name loops gave.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from beliefloc.model import GridLayout
from beliefloc.semantic_map import geometry
from beliefloc.semantic_map.compile import _annotated_states, _parse_state_names, layout_of
from beliefloc.semantic_map.schema import SemanticMap


def _reference_viewing_angles(
    layout: GridLayout, landmark: tuple[int, int], view_range: float | None, fov: float, occlusion: bool
) -> tuple[np.ndarray, np.ndarray]:
    """One landmark at a time, over its window of cells (the original implementation)."""
    lr, lc = landmark
    h_count = layout.headings
    index = geometry.cell_index_map(layout)
    if view_range is None:
        r0, r1, c0, c1 = 0, layout.rows, 0, layout.cols
    else:
        reach = math.floor(view_range / layout.cell_size + 1e-9)
        r0, r1 = max(0, lr - reach), min(layout.rows, lr + reach + 1)
        c0, c1 = max(0, lc - reach), min(layout.cols, lc + reach + 1)
    rr, cc = np.mgrid[r0:r1, c0:c1]
    rr, cc = rr.ravel(), cc.ravel()
    cells = index[rr, cc]
    keep = cells >= 0
    rr, cc, cells = rr[keep], cc[keep], cells[keep]
    dy, dx = (rr - lr).astype(float), (lc - cc).astype(float)
    distance = np.hypot(dx, dy) * layout.cell_size
    if view_range is not None:
        keep = distance <= view_range + 1e-9
        rr, cc, cells, dx, dy, distance = rr[keep], cc[keep], cells[keep], dx[keep], dy[keep], distance[keep]
    if occlusion and not layout.free.all():
        # the line-of-sight rule itself is checked against a brute-force reference in test_compile.py
        visible = geometry._line_of_sight(layout.free, rr, cc, lr, lc)
        rr, cc, cells, dx, dy, distance = (a[visible] for a in (rr, cc, cells, dx, dy, distance))
    bearing = np.degrees(np.arctan2(dx, dy))
    headings = np.arange(h_count)
    if h_count == 1:
        relative = np.zeros((len(cells), 1))
    else:
        relative = (bearing[:, None] - headings[None, :] * (360.0 / h_count) + 180.0) % 360.0 - 180.0
    relative = np.abs(relative)
    relative[distance == 0.0, :] = 0.0
    seen = relative <= fov / 2.0 + 1e-9
    states = (cells[:, None] * h_count + headings[None, :])[seen]
    return states, relative[seen]


def _random_layout(rng: np.random.Generator) -> GridLayout:
    rows, cols = int(rng.integers(1, 25)), int(rng.integers(1, 25))
    free = rng.random((rows, cols)) > rng.choice([0.0, 0.15, 0.35])
    free[int(rng.integers(rows)), int(rng.integers(cols))] = True
    headings = int(rng.choice([1, 4, 8]))
    return GridLayout(rows, cols, headings, float(rng.choice([1.0, 0.6, 1.3])), free)


def _sorted_pairs(states: np.ndarray, angles: np.ndarray) -> np.ndarray:
    order = np.lexsort((angles, states))
    return np.stack([states[order].astype(float), angles[order]])


@pytest.mark.parametrize("chunk", [None, 5])
def test_viewing_angles_many_equals_one_landmark_at_a_time(monkeypatch: pytest.MonkeyPatch, chunk: int | None) -> None:
    if chunk is not None:  # force many small chunks
        monkeypatch.setattr(geometry, "_CHUNK", chunk)
    rng = np.random.default_rng(2024)
    for _ in range(80):
        layout = _random_layout(rng)
        free_r, free_c = np.nonzero(layout.free)
        picks = rng.integers(len(free_r), size=int(rng.integers(1, 12)))
        landmarks = np.stack([free_r[picks], free_c[picks]], axis=1)
        view_range = None if rng.random() < 0.3 else float(rng.choice([0.0, 1.0, 1.5, 2.0, 3.7, 8.0]))
        fov = float(rng.choice([30.0, 90.0, 135.0, 360.0]))
        occlusion = bool(rng.random() < 0.7)
        states, angles, which = geometry.viewing_angles_many(layout, landmarks, view_range, fov, occlusion)
        for k, (lr, lc) in enumerate(landmarks.tolist()):
            expected = _reference_viewing_angles(layout, (lr, lc), view_range, fov, occlusion)
            mine = which == k
            np.testing.assert_array_equal(_sorted_pairs(states[mine], angles[mine]), _sorted_pairs(*expected))
            single = geometry.viewing_angles(layout, (lr, lc), view_range, fov, occlusion)
            np.testing.assert_array_equal(_sorted_pairs(*single), _sorted_pairs(*expected))


def test_viewing_angles_many_with_no_landmarks() -> None:
    layout = GridLayout(3, 3, 4, 1.0, np.ones((3, 3), dtype=bool))
    states, angles, which = geometry.viewing_angles_many(layout, np.zeros((0, 2), dtype=np.int64), 2.0, 90.0, True)
    assert len(states) == len(angles) == len(which) == 0


def test_annotated_states_equal_a_name_by_name_loop() -> None:
    smap = SemanticMap.model_validate(
        {
            "name": "annotated",
            "grid": {"rows": 3, "cols": 4, "headings": 4},
            "layout": "....\n.#..\n...#",
            "actions": {"forward": {}},
            "sensors": {"look": {"type": "look", "classes": ["a", "b"]}},
            "annotations": [
                {"state": "0,1", "look": ["a"]},
                {"state": "2,2,3", "look": ["b"]},
                {"states": ["0,0,1", " 1 , 2 ", "2,0, 2", "1,3", "002,01,0"], "look": ["a", "b"]},
                {"states": [], "look": []},
                {"states": ["\u00a01,0", "2,1,\t3"], "look": ["b"]},  # non-ASCII whitespace: the slow path
            ],
        }
    )
    layout = layout_of(smap)
    got = _annotated_states(smap, layout)
    assert len(got) == len(smap.annotations)
    for (states, readings), annotation in zip(got, smap.annotations, strict=True):
        expected: list[int] = []
        for name, _ in annotation.targets:
            r, c, h = smap.parse_state(name)
            first = layout.state_of(r, c)
            expected.extend(range(first, first + layout.headings) if h is None else [first + h])
        assert states.tolist() == expected
        assert states.dtype == np.int64
        assert readings == annotation.readings


def test_state_names_parse_as_a_split_per_name_would() -> None:
    rng = np.random.default_rng(5)
    spaces = ["", " ", "  ", "\t"]
    names = []
    for _ in range(2000):
        numbers = [str(int(rng.integers(0, 100_000))).zfill(int(rng.integers(0, 7))) for _ in range(rng.integers(2, 4))]
        names.append(",".join(f"{rng.choice(spaces)}{n}{rng.choice(spaces)}" for n in numbers))
    rows, cols, headings = _parse_state_names(names)
    fields = [[int(f) for f in name.split(",")] for name in names]
    assert rows.tolist() == [f[0] for f in fields]
    assert cols.tolist() == [f[1] for f in fields]
    assert headings.tolist() == [f[2] if len(f) == 3 else -1 for f in fields]
