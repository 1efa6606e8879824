"""ROS/Nav2 occupancy maps (beliefloc.semantic_map.occupancy_map): tiny images built here with Pillow and checked
against hand-computed values, a plain-loop transcription of Nav2's ``loadMapFromFile`` as the
oracle of the vectorised reading, every refusal with its message, and the real maps of
../shared/ros-maps (with Nav2's own expected cells for its test map)."""

from __future__ import annotations

import io
import math
import os
import re
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from PIL import Image

from beliefloc.cli.app import app
from beliefloc.errors import EXIT_BAD_INPUT, MapError, OccupancyMapError
from beliefloc.model import MapFrame
from beliefloc.semantic_map.occupancy_map import (
    MAX_IMAGE_BYTES,
    MAX_PIXELS,
    MAX_YAML_BYTES,
    RULE_NAMES,
    MapMode,
    MapYaml,
    Nav2Version,
    Occupancy,
    OccupancyMap,
    OccupancyRule,
    classify_pixels,
    image_size_problem,
    load_occupancy,
    load_region_mask,
    nav2_cell_values,
)

DATA = Path(__file__).resolve().parent / "data" / "occupancy"
SHARED = Path(__file__).resolve().parents[2] / "shared" / "ros-maps"
needs_shared = pytest.mark.skipif(
    not SHARED.is_dir(), reason=f"the real ROS maps are not at {SHARED} (CI keeps shared/ beside the checkout)"
)

F, X, U = Occupancy.FREE, Occupancy.OCCUPIED, Occupancy.UNKNOWN  # free, wall, unknown

# The map YAML written by write_map, one key a line in this order: a test's expected line numbers.
DEFAULTS = {
    "image": None,  # the image's file name
    "resolution": "0.5",
    "origin": "[0.0, 0.0, 0.0]",
    "negate": "0",
    "occupied_thresh": "0.65",
    "free_thresh": "0.25",  # Nav2's default, and the depot's
    "mode": None,  # absent: Nav2's default, trinary
}
LINE = {key: number for number, key in enumerate(DEFAULTS, start=1)}


def write_map(
    folder: Path,
    content: Image.Image | bytes | None,
    *,
    name: str = "map",
    fmt: str = "PNG",
    extra: str = "",
    **fields: str | None,
) -> Path:
    """``folder/name.yaml`` beside ``folder/name.<fmt>`` holding ``content`` (an image, raw bytes, or
    None for no file): ``fields`` override DEFAULTS (YAML text; None drops the key; ``image`` the file
    name written in the YAML)."""
    image_name = f"{name}.{fmt.lower()}"
    if isinstance(content, bytes):
        (folder / image_name).write_bytes(content)
    elif content is not None:
        content.save(folder / image_name, format=fmt)
    values = {**DEFAULTS, "image": image_name, **fields}
    text = "".join(f"{key}: {value}\n" for key, value in values.items() if value is not None)
    path = folder / f"{name}.yaml"
    path.write_text(text + extra)
    return path


def grey(rows: list[list[int]]) -> Image.Image:
    return Image.fromarray(np.array(rows, dtype=np.uint8), mode="L")


def rgba(rows: list[list[tuple[int, ...]]]) -> Image.Image:
    array = np.array(rows, dtype=np.uint8)
    return Image.fromarray(array, mode="RGBA" if array.shape[2] == 4 else "RGB")


def pgm16(rows: list[list[int]], maxval: int) -> bytes:
    """A binary PGM with two bytes a sample (big-endian, as the format says)."""
    array = np.array(rows)
    header = f"P5\n{array.shape[1]} {array.shape[0]}\n{maxval}\n".encode()
    return header + array.astype(">u2").tobytes()


# --- orientation and frame -----------------------------------------------------------------------


def test_the_committed_corner_map_keeps_image_order_and_places_the_pixel_in_metres():
    occupancy = load_occupancy(DATA / "corner.yaml")
    assert occupancy.pixels.tolist() == [[X, F, F, F], [F, F, F, F], [F, F, F, U]]
    assert (occupancy.height, occupancy.width) == (3, 4)
    assert occupancy.size_m == (2.0, 1.5)
    assert occupancy.frame == MapFrame(1.0, 2.0, 0.0)
    # the top-left pixel spans x 1.0..1.5 and y 3.0..3.5 (the image's top is y = 2 + 3 * 0.5)
    assert np.allclose(occupancy.pixel_centre(0, 0), (1.25, 3.25))
    assert np.allclose(occupancy.pixel_centre(2, 3), (2.75, 2.25))
    # Nav2's OccupancyGrid.data is bottom row first: the occupied pixel is its last row's first cell
    nav2_data = np.flipud(occupancy.pixels).ravel()
    assert np.flatnonzero(nav2_data == X).tolist() == [2 * 4 + 0]
    assert occupancy.warnings == ()


def test_a_yawed_origin_rotates_pixel_centres_about_the_corner(tmp_path: Path):
    image = Image.open(DATA / "corner.pgm")
    path = write_map(tmp_path, image, fmt="PPM", resolution="0.5", origin="[1.0, 2.0, 1.5707963267948966]")
    occupancy = load_occupancy(path)
    # grid-frame centre of the top-left pixel (0.25, 1.25) turned 90 degrees: (-1.25, 0.25)
    assert np.allclose(occupancy.pixel_centre(0, 0), (1.0 - 1.25, 2.0 + 0.25))
    gx, gy = occupancy.frame.to_grid(*occupancy.pixel_centre(0, 0))
    assert np.allclose((gx, gy), (0.25, 1.25))


# --- shades, channels and modes ------------------------------------------------------------------


def test_8_bit_pgm_thresholds_are_strict(tmp_path: Path):
    # occ = 1 - v/255: 0 -> 1; 89 -> 0.651; 90 -> 0.647; 191 -> 0.2510; 192 -> 0.2471; 254 -> 0.004
    path = write_map(tmp_path, grey([[0, 89, 90], [191, 192, 254]]), fmt="PPM")
    assert path.with_suffix(".ppm").read_bytes().startswith(b"P5")
    assert load_occupancy(path).pixels.tolist() == [[X, X, U], [U, F, F]]


@pytest.mark.parametrize("maxval", [1000, 65535])
def test_16_bit_pgm_is_normalised_by_its_maxval(tmp_path: Path, maxval: int):
    # as fractions of maxval: occ = 1 - v/maxval: 0 -> 1, 0.34 -> 0.66, 0.36 -> 0.64, 0.74 -> 0.26, 0.76 -> 0.24, 1 -> 0
    fractions = [[0.0, 0.34, 0.36], [0.74, 0.76, 1.0]]
    rows = [[round(f * maxval) for f in row] for row in fractions]
    path = write_map(tmp_path, pgm16(rows, maxval), fmt="PGM")
    assert load_occupancy(path).pixels.tolist() == [[X, X, U], [U, F, F]]


def test_16_bit_saver_grey_is_the_unknown_grey_too(tmp_path: Path):
    path = write_map(tmp_path, pgm16([[205 * 257, 205 * 257 + 1]], 65535), fmt="PGM")
    occupancy = load_occupancy(path)
    assert occupancy.pixels.tolist() == [[U, U]]  # Jazzy cuts both to 8 bits: grey 205, the saver's
    assert occupancy.warnings[0].startswith("2 pixels of map_saver's unknown grey 205")
    humble = load_occupancy(path, rule=OccupancyRule.NAV2_HUMBLE)  # 16 bits kept: occ 0.196 < 0.25
    assert humble.pixels.tolist() == [[F, F]] and humble.warnings == ()


def test_rgb_png_takes_the_mean_of_the_channels_under_humble(tmp_path: Path):
    # shade = mean/255: red 1/3 -> occ 0.667 X; cyan 2/3 -> occ 0.333 U; (200,255,255) -> occ 0.072 F
    image = rgba([[(255, 0, 0), (0, 255, 255), (200, 255, 255)], [(205, 205, 205), (205, 205, 206), (0, 0, 0)]])
    path = write_map(tmp_path, image)
    assert load_occupancy(path, rule=OccupancyRule.NAV2_HUMBLE).pixels.tolist() == [[X, U, F], [F, F, X]]


def test_rgb_png_takes_the_rec_601_luma_under_jazzy(tmp_path: Path):
    # g = ((306 R + 601 G + 117 B) * 257 >> 10) // 257: red 76 -> occ 0.702 X; cyan 178 -> 0.302 U;
    # (200,255,255) 238 -> 0.067 F; (205,205,206) is grey 205 too, the saver's grey under beliefloc
    image = rgba([[(255, 0, 0), (0, 255, 255), (200, 255, 255)], [(205, 205, 205), (205, 205, 206), (0, 0, 0)]])
    path = write_map(tmp_path, image)
    assert load_occupancy(path).pixels.tolist() == [[X, U, F], [U, U, X]]
    for rule in (OccupancyRule.NAV2_JAZZY, OccupancyRule("nav2")):
        assert load_occupancy(path, rule=rule).pixels.tolist() == [[X, U, F], [F, F, X]]
    occupancy = load_occupancy(path)
    assert load_region_mask(path, like=occupancy).tolist() == [[100, -1, 0], [0, 0, 100]]


def test_png_alpha_is_a_fourth_channel_in_trinary_mode_under_humble(tmp_path: Path):
    # shade = (R + G + B + A) / 4 / 255 with A = 255 opaque (Nav2's MaxRGB - opacity):
    # (254,254,254,255) -> occ 0.003 F; (254,254,254,0) -> 0.253 U; (0,0,0,255) -> 0.75 X;
    # (255,255,255,0) -> exactly 0.25, not below free_thresh 0.25: U; (205,205,205,255) -> 0.147 F (Nav2)
    image = rgba(
        [
            [(254, 254, 254, 255), (254, 254, 254, 0), (0, 0, 0, 255)],
            [(255, 255, 255, 0), (205, 205, 205, 255), (0, 0, 0, 0)],
        ]
    )
    path = write_map(tmp_path, image)
    assert load_occupancy(path, rule=OccupancyRule.NAV2_HUMBLE).pixels.tolist() == [[F, U, X], [U, F, X]]
    # Jazzy: any alpha below 255 is unknown, (0,0,0,0) included; beliefloc: and the saver's grey
    assert load_occupancy(path, rule=OccupancyRule.NAV2_JAZZY).pixels.tolist() == [[F, U, X], [U, F, U]]
    assert load_occupancy(path).pixels.tolist() == [[F, U, X], [U, U, U]]


def test_grey_with_alpha_counts_the_grey_three_times(tmp_path: Path):
    # (0, a=255): mean(0, 0, 0, 255) = 63.75 -> occ 0.75 X (averaging grey and alpha alone would give 0.5: U)
    image = Image.fromarray(np.array([[[0, 255], [254, 255]]], dtype=np.uint8), mode="LA")
    path = write_map(tmp_path, image)
    assert load_occupancy(path, rule=OccupancyRule.NAV2_HUMBLE).pixels.tolist() == [[X, F]]
    assert load_occupancy(path).pixels.tolist() == [[X, F]]  # Jazzy: opaque, alpha plays no part


def test_a_transparent_colour_of_a_grey_png_is_an_alpha_channel(tmp_path: Path):
    image = grey([[254, 200]])
    image.save(tmp_path / "map.png", transparency=200)  # tRNS: grey 200 is transparent
    path = write_map(tmp_path, None)
    # 200 transparent: mean(200, 200, 200, 0) = 150 -> occ 0.41: U (opaque 200 would be occ 0.216: F)
    assert load_occupancy(path).pixels.tolist() == [[F, U]]


def test_bmp_reads_like_pgm(tmp_path: Path):
    path = write_map(tmp_path, grey([[0, 89, 90], [191, 192, 254]]), fmt="BMP")
    assert load_occupancy(path).pixels.tolist() == [[X, X, U], [U, F, F]]


def test_a_palette_png_reads_its_colours(tmp_path: Path):
    path = write_map(tmp_path, grey([[0, 254, 205]]).convert("P"))
    assert Image.open(tmp_path / "map.png").mode == "P"
    assert load_occupancy(path).pixels.tolist() == [[X, F, U]]


def test_negate_reads_dark_as_free_and_mirrors_the_unknown_grey(tmp_path: Path):
    # occ = shade: 0 -> 0 F; 254 -> 0.996 X; 205 -> 0.804 X; 50 -> 0.196 F for Nav2, the saver's grey mirrored
    path = write_map(tmp_path, grey([[0, 254, 205, 50]]), negate="1")
    for rule in (OccupancyRule.NAV2_HUMBLE, OccupancyRule.NAV2_JAZZY):
        assert load_occupancy(path, rule=rule).pixels.tolist() == [[F, X, X, F]]
    occupancy = load_occupancy(path)
    assert occupancy.pixels.tolist() == [[F, X, X, U]]
    assert occupancy.warnings[0].startswith("1 pixels of map_saver's unknown grey 50 ")


@pytest.mark.parametrize("negate", ["true", "false"])
def test_negate_may_be_a_boolean_as_in_nav2(tmp_path: Path, negate: str):
    path = write_map(tmp_path, grey([[0]]), negate=negate)
    assert load_occupancy(path).pixels.tolist() == [[F if negate == "true" else X]]


def test_scale_mode_unknown_between_thresholds_and_where_not_opaque(tmp_path: Path):
    # no alpha in the mean: (128,128,128,255) -> occ 0.498, between: U (Nav2: rint(0.248/0.4*100) = 62);
    # (254,254,254,254) is not fully opaque: U (-1); the saver's grey 205 is a probability here: F
    image = rgba(
        [
            [(0, 0, 0, 255), (254, 254, 254, 255), (128, 128, 128, 255)],
            [(254, 254, 254, 254), (205, 205, 205, 255), (0, 0, 0, 0)],
        ]
    )
    path = write_map(tmp_path, image, mode="scale")
    occupancy = load_occupancy(path)
    assert occupancy.pixels.tolist() == [[X, F, U], [U, F, U]]
    assert occupancy.warnings == ()
    assert load_region_mask(path, like=occupancy).tolist() == [[100, 0, 62], [-1, 0, -1]]


def test_raw_mode_reads_the_value_as_percent(tmp_path: Path):
    # v in 0..100 is Nav2's cell; else -1. beliefloc: p = v/100 against the thresholds 0.65 / 0.25
    path = write_map(tmp_path, grey([[0, 20, 30, 70], [100, 101, 205, 255]]), mode="raw", negate="1")
    occupancy = load_occupancy(path)  # raw ignores negate, as Nav2
    assert occupancy.pixels.tolist() == [[F, F, U, X], [X, U, U, U]]
    assert occupancy.warnings == ()
    assert load_region_mask(path, like=occupancy).tolist() == [[0, 20, 30, 70], [100, -1, -1, -1]]


def test_mode_is_read_in_any_letter_case(tmp_path: Path):
    path = write_map(tmp_path, grey([[30]]), mode='"RAW"')
    assert load_occupancy(path).pixels.tolist() == [[U]]  # raw: 30 %; trinary would say occupied


# --- the saver's unknown grey ---------------------------------------------------------------------


def test_saver_grey_is_unknown_by_default_and_free_under_nav2_with_a_warning(tmp_path: Path):
    path = write_map(tmp_path, grey([[205, 205, 254], [205, 0, 206]]))  # free_thresh 0.25
    ours = load_occupancy(path)
    assert ours.pixels.tolist() == [[U, U, F], [U, X, F]]
    assert ours.warnings == (
        "3 pixels of map_saver's unknown grey 205 read as unknown, not free as Nav2 reads them "
        "(occ 0.196 <= free_thresh 0.25); occupancy_rule: nav2 in the map file keeps Nav2's reading",
    )
    hashes = {ours.sha256}
    for rule in (OccupancyRule.NAV2_HUMBLE, OccupancyRule.NAV2_JAZZY):
        nav2 = load_occupancy(path, rule=rule)
        assert nav2.pixels.tolist() == [[F, F, F], [F, X, F]]
        assert nav2.warnings == ()
        assert nav2.rule is rule
        hashes.add(nav2.sha256)
    assert len(hashes) == 3  # the rule is part of the content hash


def test_saver_grey_below_free_thresh_needs_no_rule(tmp_path: Path):
    path = write_map(tmp_path, grey([[205, 254]]), free_thresh="0.196")  # occ(205) = 0.19608 > 0.196
    for rule in OccupancyRule:
        occupancy = load_occupancy(path, rule=rule)
        assert occupancy.pixels.tolist() == [[U, F]]
        assert occupancy.warnings == ()


def test_rules_have_stable_names():
    assert [rule.value for rule in OccupancyRule] == ["beliefloc", "nav2-humble", "nav2-jazzy"]
    assert OccupancyRule("nav2") is OccupancyRule.NAV2_JAZZY  # the current LTS
    assert RULE_NAMES == ("beliefloc", "nav2", "nav2-humble", "nav2-jazzy")
    assert [rule.nav2 for rule in OccupancyRule] == [Nav2Version.JAZZY, Nav2Version.HUMBLE, Nav2Version.JAZZY]
    with pytest.raises(ValueError):
        OccupancyRule("nav2-iron")


# --- the oracle: Nav2's loop, pixel by pixel ------------------------------------------------------


def nav2_shade(pixel: tuple[int, ...], has_alpha: bool, params: MapYaml) -> tuple[float, float, int]:
    """``(shade, occ, opacity)`` of one 8-bit pixel (R, G, B[, A]) as Nav2's ``loadMapFromFile`` loop
    computes them, with GraphicsMagick's 16-bit quanta."""
    channels = [257 * c for c in pixel[:3]]
    opacity = 65535 - 257 * pixel[3] if has_alpha else 0  # GraphicsMagick stores opacity
    if params.mode is MapMode.TRINARY and has_alpha:
        channels.append(65535 - opacity)  # Nav2: MaxRGB - pixel.alphaQuantum()
    shade = (sum(float(c) for c in channels) / len(channels)) / 65535.0
    return shade, (shade if params.negate else 1.0 - shade), opacity


def humble_reference(pixel: tuple[int, ...], has_alpha: bool, params: MapYaml) -> tuple[int, Occupancy]:
    """The OccupancyGrid cell Nav2 Humble's loop makes of one pixel, and beliefloc's class of it."""
    shade, occ, opacity = nav2_shade(pixel, has_alpha, params)
    if params.mode is MapMode.RAW:
        percent = math.floor(shade * 255 + 0.5)
        if not 0 <= percent <= 100:
            return -1, U
        p = percent / 100.0
        return percent, X if p > params.occupied_thresh else F if p < params.free_thresh else U
    if params.mode is MapMode.SCALE and opacity != 0:
        return -1, U
    if params.occupied_thresh < occ:
        return 100, X
    if occ < params.free_thresh:
        return 0, F
    if params.mode is MapMode.TRINARY:
        return -1, U
    between = (occ - params.free_thresh) / (params.occupied_thresh - params.free_thresh) * 100.0
    return round(between), U  # std::rint: half to even, as round()


def jazzy_reference(pixel: tuple[int, ...], has_alpha: bool, params: MapYaml) -> tuple[int, Occupancy]:
    """The OccupancyGrid cell Nav2 Jazzy's Eigen code makes of one pixel, and beliefloc's class of it:
    one pixel at a time in numpy float32 scalars (Eigen's float arrays)."""
    r, g, b = (257 * c for c in pixel[:3])
    grey = ((306 * r + 601 * g + 117 * b) >> 10) // 257  # PixelIntensityRec601, ScaleQuantumToChar
    if params.mode is MapMode.RAW:
        if grey > 100:
            return -1, U
        p = grey / 100.0
        return grey, X if p >= params.occupied_thresh else F if p <= params.free_thresh else U
    f32 = np.float32
    occ = f32(grey) / f32(255.0)
    if not params.negate:
        occ = f32(1.0) - occ
    transparent = has_alpha and pixel[3] < 255
    value, kind = -1, U
    if occ >= f32(params.occupied_thresh):
        value, kind = 100, X
    if occ <= f32(params.free_thresh):
        value, kind = 0, F
    if params.mode is MapMode.SCALE and f32(params.free_thresh) < occ < f32(params.occupied_thresh):
        scaled = (occ - f32(params.free_thresh)) / f32(params.occupied_thresh - params.free_thresh) * f32(100.0)
        value = math.floor(float(scaled) + 0.5)  # std::round of a positive float; exact in double
    return (-1, U) if transparent else (value, kind)


def nav2_reference(pixel: tuple[int, ...], has_alpha: bool, params: MapYaml, version: Nav2Version) -> int:
    reference = humble_reference if version is Nav2Version.HUMBLE else jazzy_reference
    return reference(pixel, has_alpha, params)[0]


def beliefloc_reference(pixel: tuple[int, ...], has_alpha: bool, params: MapYaml, rule: OccupancyRule) -> Occupancy:
    """The module's table under ``rule``, for one pixel."""
    reference = humble_reference if rule.nav2 is Nav2Version.HUMBLE else jazzy_reference
    kind = reference(pixel, has_alpha, params)[1]
    if params.mode is MapMode.TRINARY and rule is OccupancyRule.BELIEFLOC and kind is F:
        saver = 50 if params.negate else 205
        r, g, b = (257 * c for c in pixel[:3])
        if ((306 * r + 601 * g + 117 * b) >> 10) // 257 == saver:
            return U
    return kind


@settings(max_examples=80, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    mode=st.sampled_from(list(MapMode)),
    negate=st.integers(0, 1),
    has_alpha=st.booleans(),
    free=st.floats(0.0, 0.6),
    gap=st.floats(0.01, 0.4),
    rule=st.sampled_from(list(OccupancyRule)),
)
def test_vectorised_reading_matches_each_nav2_release_pixel_by_pixel(
    seed: int, mode: MapMode, negate: int, has_alpha: bool, free: float, gap: float, rule: OccupancyRule
):
    rng = np.random.default_rng(seed)
    palette = np.array([0, 1, 50, 100, 101, 127, 128, 205, 206, 254, 255])  # the interesting values
    shape = (3, 4, 4 if has_alpha else 3)
    image = rng.choice(palette, size=shape) if seed % 2 else rng.integers(0, 256, size=shape)
    if seed % 3 == 0:
        image[..., 1] = image[..., 2] = image[..., 0]  # grey pixels: the saver's grey among them
    params = MapYaml(
        image="x.png",
        resolution=1.0,
        origin=(0.0, 0.0, 0.0),
        negate=negate,
        free_thresh=free,
        occupied_thresh=min(1.0, free + gap),
        mode=mode,
    )
    colour = image[..., :3].astype(np.uint16) * np.uint16(257)
    alpha = image[..., 3].astype(np.uint16) * np.uint16(257) if has_alpha else None
    values = nav2_cell_values(colour, alpha, params, rule.nav2)
    pixels, reclassified = classify_pixels(colour, alpha, params, rule)
    flipped = 0
    for i in range(shape[0]):
        for j in range(shape[1]):
            pixel = tuple(int(c) for c in image[i, j])
            assert values[i, j] == nav2_reference(pixel, has_alpha, params, rule.nav2), (i, j, pixel)
            expected = beliefloc_reference(pixel, has_alpha, params, rule)
            assert pixels[i, j] == expected, (i, j, pixel)
            plain = beliefloc_reference(pixel, has_alpha, params, OccupancyRule.NAV2_JAZZY)
            flipped += int(rule is OccupancyRule.BELIEFLOC and expected is U and plain is F)
    assert reclassified == flipped


# --- warnings -------------------------------------------------------------------------------------


def test_a_nan_yaw_is_read_as_zero_with_a_warning(tmp_path: Path):
    path = write_map(tmp_path, grey([[254]]), origin="[1.0, 2.0, .nan]")
    occupancy = load_occupancy(path)
    assert occupancy.frame == MapFrame(1.0, 2.0, 0.0)
    assert len(occupancy.warnings) == 1
    assert occupancy.warnings[0] == "line 3, column 20: origin[2]: the yaw is NaN; read as 0 (no rotation)"


def test_keys_nav2_ignores_are_ignored_with_a_warning(tmp_path: Path):
    path = write_map(tmp_path, grey([[254]]), extra="modes: raw\n")
    occupancy = load_occupancy(path)
    assert occupancy.pixels.tolist() == [[F]]
    assert occupancy.warnings[0].startswith("line 7, column 1: modes: unknown key 'modes' ignored (Nav2 ignores it")


# --- refusals -------------------------------------------------------------------------------------


def _at(key: str, field: str | None = None) -> str:
    """``map.yaml:<line>:<col>: <field>: `` for a key written by write_map."""
    return rf"map\.yaml:{LINE[key]}:\d+: {re.escape(field or key)}: "


BAD_FIELDS = [
    ({"resolution": "0"}, _at("resolution") + "should be greater than 0, got 0"),
    ({"resolution": "-0.05"}, _at("resolution") + "should be greater than 0, got -0.05"),
    ({"resolution": ".nan"}, _at("resolution") + "should be greater than 0, got nan"),
    ({"resolution": "true"}, _at("resolution") + "should be a number, got true"),
    ({"resolution": None}, r"map\.yaml:1:1: required key 'resolution' is missing"),
    ({"origin": "[0.0, 0.0]"}, _at("origin") + r"should be three numbers \[x, y, yaw\] .*got 2 values"),
    ({"origin": "[0, 0, 0, 0]"}, _at("origin") + r"should be three numbers .*got 4 values"),
    ({"origin": "0 0 0"}, _at("origin") + r"should be three numbers .*got '0 0 0'"),
    ({"origin": "[.inf, 0, 0]"}, _at("origin", "origin[0]") + "should be a finite number"),
    ({"origin": "[0, .nan, 0]"}, _at("origin", "origin[1]") + "should be a finite number"),
    ({"origin": "[0, north, 0]"}, _at("origin", "origin[1]") + "should be a number, got 'north'"),
    ({"origin": "[0, 0, -.inf]"}, _at("origin", "origin[2]") + "the yaw should be a finite number of radians"),
    ({"negate": "2"}, _at("negate") + r"should be 0 or 1 \(or false / true\), got 2"),
    ({"occupied_thresh": "1.5"}, _at("occupied_thresh") + "should be less than or equal to 1, got 1.5"),
    ({"free_thresh": "-0.1"}, _at("free_thresh") + "should be greater than or equal to 0, got -0.1"),
    ({"free_thresh": "0.7"}, _at("free_thresh") + r"should be less than occupied_thresh \(0.65\), got 0.7"),
    ({"free_thresh": "0.65"}, _at("free_thresh") + r"should be less than occupied_thresh \(0.65\), got 0.65"),
    ({"mode": "binary"}, _at("mode") + "should be 'trinary', 'scale' or 'raw', got 'binary'"),
    ({"image": '""'}, _at("image") + "should name the image file"),
]


@pytest.mark.parametrize(("fields", "message"), BAD_FIELDS, ids=[str(f) for f, _ in BAD_FIELDS])
def test_bad_fields_are_refused_at_their_line(tmp_path: Path, fields: dict[str, str | None], message: str):
    path = write_map(tmp_path, grey([[254]]), **fields)
    with pytest.raises(OccupancyMapError, match=message):
        load_occupancy(path)


def test_a_yaml_that_is_not_a_mapping_is_refused(tmp_path: Path):
    path = tmp_path / "map.yaml"
    path.write_text("- image: map.png\n")
    with pytest.raises(OccupancyMapError, match=r"map\.yaml:1:1: a map YAML is a mapping \(image:"):
        load_occupancy(path)


def test_broken_yaml_and_missing_yaml_are_refused(tmp_path: Path):
    path = tmp_path / "map.yaml"
    path.write_text("image: [map.png\n")
    with pytest.raises(OccupancyMapError, match=r"map\.yaml:2:1: YAML syntax error"):
        load_occupancy(path)
    with pytest.raises(OccupancyMapError, match=r"nothere\.yaml: no such file"):
        load_occupancy(tmp_path / "nothere.yaml")


def test_an_oversized_yaml_is_refused_before_it_is_read(tmp_path: Path):
    path = tmp_path / "map.yaml"
    with path.open("wb") as handle:
        handle.truncate(MAX_YAML_BYTES + 1)  # sparse: nothing written
    with pytest.raises(OccupancyMapError, match=r"map\.yaml: 1,048,577 bytes is more than a map YAML's limit of 1,"):
        load_occupancy(path)


def test_a_missing_image_is_named_at_the_image_line(tmp_path: Path):
    path = write_map(tmp_path, None, image="nothere.png")
    with pytest.raises(OccupancyMapError, match=_at("image") + r".*nothere\.png: no such file"):
        load_occupancy(path)


def test_an_image_that_is_a_folder_is_refused(tmp_path: Path):
    (tmp_path / "folder.png").mkdir()
    path = write_map(tmp_path, None, image="folder.png")
    with pytest.raises(OccupancyMapError, match=_at("image") + r".*folder\.png: is not a regular file"):
        load_occupancy(path)


def _png_bytes(image: Image.Image) -> bytes:
    buffer = io.BytesIO()
    image.save(buffer, format="PNG")
    return buffer.getvalue()


def _truncated_png() -> bytes:
    """A noisy 32 x 32 PNG cut in the middle of its pixel data."""
    noise = np.random.default_rng(0).integers(0, 256, size=(32, 32), dtype=np.uint8)
    data = _png_bytes(Image.fromarray(noise, mode="L"))
    return data[: len(data) // 2]


def _eps_bytes() -> bytes:
    buffer = io.BytesIO()
    grey([[254]]).save(buffer, format="EPS")  # Pillow would need Ghostscript to open it
    return buffer.getvalue()


def _float_tiff_bytes() -> bytes:
    buffer = io.BytesIO()
    Image.fromarray(np.array([[0.5]], dtype=np.float32), mode="F").save(buffer, format="TIFF")
    return buffer.getvalue()


BAD_IMAGES = [
    ("text", b"not an image at all\n", r"is not an image in a format beliefloc reads \(PPM, PNG, BMP"),
    ("eps", _eps_bytes(), r"is not an image in a format beliefloc reads"),
    ("truncated", _truncated_png(), r"cannot be read as an image \(image file is truncated"),
    ("float", _float_tiff_bytes(), r"has pixel mode F, which beliefloc does not read"),
    ("no pixels", b"P5\n0 0\n255\n", r"is not an image in a format beliefloc reads"),
    (
        "too many pixels",
        b"P5\n8000 8000\n255\n",
        r"is 8000 x 8000 = 64,000,000 pixels, more than the limit of 50,000,000",
    ),
    ("bomb", b"P5\n20000 20000\n255\n", r"has more than the limit of 50,000,000 pixels"),
]


@pytest.mark.parametrize(("data", "message"), [b[1:] for b in BAD_IMAGES], ids=[b[0] for b in BAD_IMAGES])
def test_bad_images_are_named_at_the_image_line(tmp_path: Path, data: bytes, message: str):
    # "too many pixels" has a header and no data: refused from the header, before any decoding
    path = write_map(tmp_path, data, fmt="img")
    with pytest.raises(OccupancyMapError, match=_at("image") + r".*map\.img: " + message):
        load_occupancy(path)


def test_an_oversized_image_file_is_refused_before_it_is_read(tmp_path: Path):
    image = tmp_path / "map.png"
    with image.open("wb") as handle:
        handle.truncate(MAX_IMAGE_BYTES + 1)  # sparse
    path = write_map(tmp_path, None)
    with pytest.raises(OccupancyMapError, match=r"400,000,001 bytes is more than the limit of 400,000,000 bytes"):
        load_occupancy(path)


def test_image_size_problems():
    assert image_size_problem(0, 5) == "is 0 x 5 pixels: a map needs at least one"
    assert image_size_problem(5, 0) is not None
    assert image_size_problem(1, MAX_PIXELS) is None
    assert image_size_problem(2, MAX_PIXELS // 2 + 1) is not None


def test_errors_are_map_errors_with_exit_code_2_through_the_cli(tmp_path: Path, runner):
    assert issubclass(OccupancyMapError, MapError)
    assert OccupancyMapError.exit_code == EXIT_BAD_INPUT == 2
    write_map(tmp_path, grey([[254]]), name="floor", resolution="0")
    smap = tmp_path / "site.yaml"
    smap.write_text("name: site\noccupancy: floor.yaml\ngrid: {cell_size: 1.0}\nactions: {forward: {cost: 1}}\n")
    result = runner.invoke(app, ["validate", str(smap)])
    assert result.exit_code == EXIT_BAD_INPUT
    assert "floor.yaml:2:" in result.output and "resolution: should be greater than 0" in result.output
    assert "Traceback" not in result.output


def test_no_file_handle_is_left_open(tmp_path: Path):
    fds = Path("/proc/self/fd")
    if not fds.is_dir():
        pytest.skip("needs /proc/self/fd to count open files")
    good = write_map(tmp_path, grey([[254, 0]]), name="good")
    bad = write_map(tmp_path, _truncated_png(), name="bad")
    before = len(os.listdir(fds))
    for _ in range(20):
        load_occupancy(good)
        with pytest.raises(OccupancyMapError):
            load_occupancy(bad)
    assert len(os.listdir(fds)) == before


# --- the result -----------------------------------------------------------------------------------


def test_the_result_is_read_only_and_blocked_is_occupied_or_unknown(tmp_path: Path):
    occupancy = load_occupancy(write_map(tmp_path, grey([[0, 254, 205]])))
    assert occupancy.pixels.dtype == np.uint8
    with pytest.raises(ValueError, match="read-only"):
        occupancy.pixels[0, 0] = F
    assert occupancy.blocked().tolist() == [[True, False, True]]
    assert occupancy.blocked() is occupancy.blocked()  # computed once
    with pytest.raises(ValueError, match="read-only"):
        occupancy.blocked()[0, 0] = False


def test_the_content_hash_follows_the_bytes(tmp_path: Path):
    path = write_map(tmp_path, grey([[0, 254]]))
    first = load_occupancy(path).sha256
    assert load_occupancy(path).sha256 == first
    write_map(tmp_path, grey([[0, 253]]))
    assert load_occupancy(path).sha256 != first


@pytest.mark.parametrize(
    ("pixels", "resolution", "message"),
    [
        (np.zeros((0, 3), dtype=np.uint8), 1.0, "non-empty 2-D uint8"),
        (np.zeros((2, 2), dtype=np.int64), 1.0, "non-empty 2-D uint8"),
        (np.full((2, 2), 3, dtype=np.uint8), 1.0, "holds 3, not an Occupancy"),
        (np.zeros((2, 2), dtype=np.uint8), 0.0, "resolution must be > 0"),
    ],
)
def test_an_occupancy_map_checks_what_it_is_built_from(pixels: np.ndarray, resolution: float, message: str):
    with pytest.raises(ValueError, match=message):
        OccupancyMap(Path("m.yaml"), Path("m.png"), resolution, MapFrame(), pixels, "0" * 64)


# --- region masks ---------------------------------------------------------------------------------


def test_a_raw_region_mask_reads_the_painted_values(tmp_path: Path):
    occupancy = load_occupancy(write_map(tmp_path, grey([[254, 254, 254], [254, 254, 254]])))
    mask = write_map(tmp_path, grey([[1, 2, 3], [0, 101, 255]]), name="rooms", mode="raw")
    region = load_region_mask(mask, like=occupancy)
    assert region.tolist() == [[1, 2, 3], [0, -1, -1]]  # row 0 at the top, like the map
    assert region.dtype == np.int16


@pytest.mark.parametrize(
    ("fields", "size", "message"),
    [
        ({"resolution": "0.1"}, (3, 2), r"rooms\.yaml:2:\d+: resolution: 0\.1 differs from the map's 0\.5; "),
        ({"origin": "[0.0, 1.0, 0.0]"}, (3, 2), r"rooms\.yaml:3:\d+: origin\[1\]: y 1 differs from the map's 0; "),
        ({"origin": "[0.0, 0.0, 0.5]"}, (3, 2), r"rooms\.yaml:3:\d+: origin\[2\]: yaw 0\.5 differs from the map's 0; "),
        ({}, (2, 3), r"rooms\.yaml:1:\d+: image: .*rooms\.png: is 3 x 2 pixels, the map's image .*map\.png 2 x 3; "),
    ],
)
def test_a_region_mask_unlike_its_map_is_refused_naming_both(
    tmp_path: Path, fields: dict[str, str], size: tuple[int, int], message: str
):
    occupancy = load_occupancy(write_map(tmp_path, Image.new("L", size, 254)))
    mask = write_map(tmp_path, grey([[1, 2, 3], [1, 2, 3]]), name="rooms", mode="raw", **fields)
    with pytest.raises(OccupancyMapError, match=message + r"a region mask must have .* of its map .*map\.yaml"):
        load_region_mask(mask, like=occupancy)


# --- the real maps --------------------------------------------------------------------------------


@needs_shared
def test_depot_loads_with_the_saver_grey_unknown():
    occupancy = load_occupancy(SHARED / "depot.yaml")
    assert (occupancy.width, occupancy.height) == (604, 307)
    assert occupancy.frame == MapFrame(0.0, 0.0, 0.0)
    assert occupancy.resolution == 0.05
    assert np.bincount(occupancy.pixels.ravel(), minlength=3).tolist() == [170587, 5947, 8894]
    assert occupancy.warnings[0].startswith("8894 pixels of map_saver's unknown grey 205 read as unknown")
    for rule in (OccupancyRule.NAV2_HUMBLE, OccupancyRule.NAV2_JAZZY):
        nav2 = load_occupancy(SHARED / "depot.yaml", rule=rule)
        assert np.bincount(nav2.pixels.ravel(), minlength=3).tolist() == [170587 + 8894, 5947, 0]


@needs_shared
def test_tb3_sandbox_free_thresh_0_196_keeps_205_unknown_under_both_rules():
    ours = load_occupancy(SHARED / "tb3_sandbox.yaml")
    assert (ours.width, ours.height) == (384, 384)
    assert ours.frame == MapFrame(-10.0, -10.0, 0.0)
    for rule in (OccupancyRule.NAV2_HUMBLE, OccupancyRule.NAV2_JAZZY):
        nav2 = load_occupancy(SHARED / "tb3_sandbox.yaml", rule=rule)
        np.testing.assert_array_equal(ours.pixels, nav2.pixels)
        assert nav2.warnings == ()
    assert np.bincount(ours.pixels.ravel(), minlength=3).tolist() == [7903, 870, 138683]
    assert ours.warnings == ()


# Nav2's own expectation for testmap.png (nav2_map_server/test/test_constants.cpp,
# g_valid_image_content): OccupancyGrid.data, the bottom row first.
NAV2_TESTMAP = [
    [0, 0, 0, 0, 0, 0, 0, 0, 0, 0],
    [100, 100, 100, 100, 0, 0, 100, 100, 100, 0],
    [100, 100, 100, 100, 0, 0, 100, 100, 100, 0],
    [100, 0, 0, 0, 0, 0, 0, 0, 0, 0],
    [100, 0, 0, 0, 0, 0, 0, 0, 0, 0],
    [100, 0, 0, 0, 0, 0, 100, 100, 0, 0],
    [100, 0, 0, 0, 0, 0, 100, 100, 0, 0],
    [100, 0, 0, 0, 0, 0, 100, 100, 0, 0],
    [100, 0, 0, 0, 0, 0, 100, 100, 0, 0],
    [100, 0, 0, 0, 0, 0, 0, 0, 0, 0],
]


@needs_shared
def test_testmap_png_matches_nav2s_own_expectation_and_its_yaw():
    occupancy = load_occupancy(SHARED / "testmap.yaml")
    assert occupancy.frame == MapFrame(2.0, 3.0, 1.0)
    assert occupancy.resolution == 0.1
    expected = np.flipud(np.array(NAV2_TESTMAP))  # image order: top row first
    assert load_region_mask(SHARED / "testmap.yaml", like=occupancy).tolist() == expected.tolist()
    np.testing.assert_array_equal(occupancy.pixels, np.where(expected == 100, X, F))
    # the bottom-left pixel's centre: (0.05, 0.05) in the grid frame, turned by 1 rad about (2, 3)
    c, s = math.cos(1.0), math.sin(1.0)
    assert np.allclose(occupancy.pixel_centre(9, 0), (2.0 + 0.05 * (c - s), 3.0 + 0.05 * (s + c)))


@needs_shared
def test_depot_keepout_is_a_mask_of_the_depot():
    depot = load_occupancy(SHARED / "depot.yaml")
    values = load_region_mask(SHARED / "depot_keepout.yaml", like=depot)
    assert values.shape == (307, 604)
    kinds, counts = np.unique(values, return_counts=True)
    # Nav2's own reading: its filters see the mask's unknown grey 205 as 0 (free_thresh 0.25), no -1
    assert dict(zip(kinds.tolist(), counts.tolist(), strict=True)) == {0: 149422 + 4793, 100: 31213}


# --- Nav2's own test images, and the fixtures on which Humble and Jazzy differ ---------------------

RELEASES = (OccupancyRule.NAV2_HUMBLE, OccupancyRule.NAV2_JAZZY)


def nav2_testmap_cells() -> np.ndarray:
    """Nav2's expected cells for testmap.png/.pgm/.bmp in image order (top row first), recreated from
    ``g_valid_image_content`` in nav2_map_server/test/test_constants.cpp (bottom row first there)."""
    return np.flipud(np.array(NAV2_TESTMAP, dtype=np.int16))


@pytest.mark.parametrize(("fmt", "mode"), [("PNG", "RGB"), ("PGM", "L"), ("BMP", "L"), ("BMP", "RGB")])
@pytest.mark.parametrize("rule", RELEASES)
def test_nav2s_testmap_in_every_format_reads_as_nav2_expects(tmp_path: Path, fmt: str, mode: str, rule: OccupancyRule):
    """Nav2's MapIOTester.loadSaveValid{PNG,PGM,BMP}: black for 100, white for 0; its thresholds
    (free 0.196, occupied 0.65, test_constants.cpp), origin (2, 3, 1) and resolution 0.1."""
    cells = nav2_testmap_cells()
    image = Image.fromarray(np.where(cells == 100, 0, 255).astype(np.uint8), mode="L").convert(mode)
    content: Image.Image | bytes = image
    if fmt == "PGM":  # Pillow writes PGM as its PPM format
        buffer = io.BytesIO()
        image.save(buffer, format="PPM")
        content = buffer.getvalue()
        assert content.startswith(b"P5")
    path = write_map(tmp_path, content, fmt=fmt, resolution="0.1", origin="[2.0, 3.0, 1.0]", free_thresh="0.196")
    occupancy = load_occupancy(path, rule=rule)
    assert load_region_mask(path, like=occupancy).tolist() == cells.tolist()
    np.testing.assert_array_equal(occupancy.pixels, np.where(cells == 100, X, F))


def nav2_saved(cells: np.ndarray, mode: MapMode) -> Image.Image:
    """The image Nav2's map saver (tryWriteMapToFile) writes for ``cells`` (-1..100) in ``mode``:
    trinary: 254 free, 0 occupied, 205 else (grey); scale: grey (100 - c) / 100 with alpha, unknown
    transparent (RGBA: the saver uses TrueColorMatte); raw: the grey c, unknown 255."""
    if mode is MapMode.TRINARY:
        values = np.where(cells < 0, 205, np.where(cells <= 25, 254, np.where(cells >= 65, 0, 205)))
        return Image.fromarray(values.astype(np.uint8), mode="L")
    if mode is MapMode.SCALE:
        shade = np.rint(np.where(cells < 0, 0.5, (100.0 - cells) / 100.0) * 255).astype(np.uint8)
        alpha = np.where(cells < 0, 0, 255).astype(np.uint8)
        return Image.fromarray(np.stack([shade, shade, shade, alpha], axis=2), mode="RGBA")
    return Image.fromarray(np.where(cells < 0, 255, cells).astype(np.uint8), mode="L")


@pytest.mark.parametrize("mode", list(MapMode))
@pytest.mark.parametrize("rule", RELEASES)
def test_nav2s_testmap_saved_in_each_mode_reads_back_as_nav2_expects(
    tmp_path: Path, mode: MapMode, rule: OccupancyRule
):
    """Nav2's MapIOTester.loadSaveMapModes: the test map saved by the saver in trinary (thresholds
    0.65 / 0.25 in the saved YAML), scale and raw (the test's 0.65 / 0.196) loads back unchanged."""
    cells = nav2_testmap_cells()
    free = "0.25" if mode is MapMode.TRINARY else "0.196"
    path = write_map(tmp_path, nav2_saved(cells, mode), free_thresh=free, mode=mode.value)
    occupancy = load_occupancy(path, rule=rule)
    assert load_region_mask(path, like=occupancy).tolist() == cells.tolist()


def test_a_grey_on_the_occupied_threshold_is_occupied_under_jazzy_and_unknown_under_humble(tmp_path: Path):
    # thresholds 0.2 / 0.6: grey 102 has occ = 1 - 102/255 = 0.6 exactly (Humble: 0.6 < 0.6 is false;
    # Jazzy: 0.6 >= 0.6); grey 204 has occ 0.2: free under Jazzy (<=), and under Humble too, only
    # because 1 - 0.8 is 0.19999999999999996 in double, just below 0.2
    path = write_map(tmp_path, grey([[102, 204, 150]]), occupied_thresh="0.6", free_thresh="0.2")
    humble = load_occupancy(path, rule=OccupancyRule.NAV2_HUMBLE)
    jazzy = load_occupancy(path, rule=OccupancyRule.NAV2_JAZZY)
    assert humble.pixels.tolist() == [[U, F, U]]
    assert jazzy.pixels.tolist() == [[X, F, U]]
    assert load_occupancy(path).pixels.tolist() == [[X, F, U]]  # beliefloc starts from Jazzy
    assert load_region_mask(path, like=humble).tolist() == [[-1, 0, -1]]
    assert load_region_mask(path, like=jazzy).tolist() == [[100, 0, -1]]


def test_an_opaque_ish_white_pixel_is_free_under_humble_and_unknown_under_jazzy(tmp_path: Path):
    # (255,255,255,254): Humble's trinary mean (255+255+255+254)/4 -> occ 0.001: free;
    # Jazzy: alpha 254 < 255 -> unknown, in trinary and in scale alike
    image = rgba([[(255, 255, 255, 254), (255, 255, 255, 255), (0, 0, 0, 254)]])
    trinary = write_map(tmp_path, image)
    assert load_occupancy(trinary, rule=OccupancyRule.NAV2_HUMBLE).pixels.tolist() == [[F, F, X]]
    assert load_occupancy(trinary, rule=OccupancyRule.NAV2_JAZZY).pixels.tolist() == [[U, F, U]]
    assert load_occupancy(trinary).pixels.tolist() == [[U, F, U]]
    scale = write_map(tmp_path, image, name="scale", mode="scale")
    for rule in RELEASES:  # scale: Humble too wants a fully opaque pixel
        assert load_occupancy(scale, rule=rule).pixels.tolist() == [[U, F, U]]


def test_scale_rounds_half_to_even_under_humble_and_away_from_zero_in_float32_under_jazzy(tmp_path: Path):
    # thresholds 0.1 / 0.9, grey 102: occ 0.6, 100 (0.6 - 0.1) / 0.8 = 62.5: Humble rint -> 62,
    # Jazzy round -> 63; grey 153: occ 0.4, 37.5 in double (Humble 38) but 37.4999... in float32 (Jazzy 37)
    path = write_map(tmp_path, grey([[102, 153]]), occupied_thresh="0.9", free_thresh="0.1", mode="scale")
    humble = load_occupancy(path, rule=OccupancyRule.NAV2_HUMBLE)
    jazzy = load_occupancy(path, rule=OccupancyRule.NAV2_JAZZY)
    assert load_region_mask(path, like=humble).tolist() == [[62, 38]]
    assert load_region_mask(path, like=jazzy).tolist() == [[63, 37]]
    assert humble.pixels.tolist() == jazzy.pixels.tolist() == [[U, U]]  # in between: unknown for beliefloc


def test_a_16_bit_grey_is_cut_to_8_bits_under_jazzy(tmp_path: Path):
    # thresholds 0.2 / 0.6, 16-bit grey 102 * 257 + 200: Humble occ 0.59695 (unknown); Jazzy cuts it to
    # 102 (occ 0.6, occupied); 204 * 257 + 256 -> Jazzy 204 (occ 0.2, free), Humble occ 0.19648 (free)
    path = write_map(
        tmp_path,
        pgm16([[102 * 257 + 200, 204 * 257 + 256]], 65535),
        fmt="PGM",
        occupied_thresh="0.6",
        free_thresh="0.2",
    )
    assert load_occupancy(path, rule=OccupancyRule.NAV2_HUMBLE).pixels.tolist() == [[U, F]]
    assert load_occupancy(path, rule=OccupancyRule.NAV2_JAZZY).pixels.tolist() == [[X, F]]


def test_raw_reads_the_luma_under_jazzy_and_the_mean_under_humble(tmp_path: Path):
    # (90, 90, 150): Humble round(255 * mean / 255) = 110 -> -1; Jazzy luma ((306 + 601) 90 + 117 150) >> 10 = 96
    path = write_map(tmp_path, rgba([[(90, 90, 150), (40, 40, 40)]]), mode="raw")
    humble = load_occupancy(path, rule=OccupancyRule.NAV2_HUMBLE)
    jazzy = load_occupancy(path, rule=OccupancyRule.NAV2_JAZZY)
    assert load_region_mask(path, like=humble).tolist() == [[-1, 40]]
    assert load_region_mask(path, like=jazzy).tolist() == [[96, 40]]
    # p = v / 100 against 0.65 / 0.25: 0.96 occupied, 0.40 in between
    assert humble.pixels.tolist() == [[U, U]] and jazzy.pixels.tolist() == [[X, U]]
