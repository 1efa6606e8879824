"""Occupancy maps saved by ROS ``map_saver`` / Nav2: a map YAML beside a PGM/PNG/BMP image, read the
way Nav2's map server reads them (``nav2_map_server``: ``loadMapYaml`` and ``loadMapFromFile`` in
``map_io.cpp``), then sorted into beliefloc's three kinds of pixel.

**The YAML.** ``image`` (relative to the YAML's folder, or absolute), ``resolution`` (metres per
pixel, > 0), ``origin`` ``[x, y, yaw]`` (the pose of the image's lower-left corner in the map frame),
``negate`` (0/1), ``occupied_thresh`` and ``free_thresh`` (in [0, 1], free < occupied), and an
optional ``mode``: ``trinary`` (the default), ``scale`` or ``raw``, in any letter case. Nav2 reads
the same keys and ignores any other; so does this module (with a warning naming the key).
Stricter than Nav2, which takes these values as written: a resolution <= 0, thresholds outside
[0, 1] or ``free_thresh >= occupied_thresh`` (Nav2's map *saver* refuses those too), a non-finite
x or y, a ``negate`` other than 0/1/true/false and ``true``/``false`` where a number belongs are
errors. A NaN yaw (``.nan``) is read as 0 with a warning.

**The pixels, by Nav2 release.** Nav2 reads images with GraphicsMagick in its 16-bit build
(Ubuntu's), so every channel is a *quantum* ``q`` in 0..65535: an 8-bit value ``v`` is ``257 v``; a
PGM of any ``maxval`` M is scaled to full range, ``q ~ 65535 v / M`` (Pillow scales it to 16 bits, or
to 8 bits when M < 256, as GraphicsMagick does; the two may round apart by less than 1/255 of a
shade for such small M). ``A`` is the alpha quantum (65535 = opaque; GraphicsMagick stores
opacity, Nav2 reads ``MaxRGB - opacity``). ``map_io.cpp`` was rewritten with Eigen for Jazzy, and
the two releases read the same image differently; each :class:`OccupancyRule` names the one it
follows (:attr:`OccupancyRule.nav2`), and each is a plain transcription of that release's
``loadMapFromFile``:

============  =========================================  ==============================================
              **Humble** (``nav2-humble``)               **Jazzy** (``nav2-jazzy`` = ``nav2``)
============  =========================================  ==============================================
grey          ``shade = mean(q_R, q_G, q_B [, A])/65535``  ``g`` = Rec. 601 luma ``(306 q_R + 601 q_G +
              in float64; A joins the mean in trinary    117 q_B) >> 10``, cut to 8 bits (``q / 257``
              mode when the image has alpha              truncated): a 16-bit image loses its low byte
occ           ``shade``, or ``1 - shade`` unless negate  ``g / 255`` in float32, ``1 -`` it unless negate
trinary       100 if ``occ > occupied_thresh``, 0 if     100 if ``occ >= occupied_thresh``, 0 if
              ``occ < free_thresh``, else -1             ``occ <= free_thresh`` (float32), else -1
scale         -1 if ``A`` is not opaque; else as         as trinary; strictly in between
              trinary; in between ``rint(100 (occ -      ``round(100 (occ - free) / (occupied - free))``
              free) / (occupied - free))`` (half even)   in float32, halves away from zero
alpha         trinary: in the mean; scale: see above     any pixel with 8-bit alpha < 255 is -1, in
                                                         trinary and scale
raw           ``v = round(255 shade)``; v if v <= 100,   ``g`` if ``g <= 100``, else -1
              else -1 (no alpha, negate ignored)         (no alpha, negate ignored)
============  =========================================  ==============================================

So, with thresholds 0.2 / 0.6, a grey of 102 (``occ = 0.6``) is occupied under Jazzy and unknown
under Humble; an opaque-ish white pixel (alpha 254) is free under Humble's trinary (the alpha
barely moves the mean) and unknown under Jazzy; a pure red pixel has Humble's shade 1/3 (occ 0.67)
and Jazzy's luma 76 (occ 0.70).

beliefloc's :class:`Occupancy` of a pixel (:func:`classify_pixels`) follows the release's
thresholds: OCCUPIED where Nav2 writes 100 by the occupied threshold, FREE where it writes 0 by the
free threshold, UNKNOWN everywhere else -- in scale mode also the pixels in between (a pixel the
map is unsure of is neither a place the robot can be nor a clear line of sight). In raw mode
(Nav2 has no thresholds there) a value ``v <= 100`` is read as ``p = v / 100`` against the
thresholds with the release's comparisons; 101..255 (map_saver writes 255 for unknown) is UNKNOWN.
:func:`nav2_cell_values` gives Nav2's cell values themselves.

**The saver's unknown grey** (rule :attr:`OccupancyRule.BELIEFLOC`, the default: Nav2 Jazzy's
reading plus this one change). ``map_saver`` writes unknown space as grey 205, whose
``occ = 1 - 205/255 = 0.196...``; any ``free_thresh`` above that -- Nav2's default 0.25, the
depot's -- makes Nav2 load unknown space as *free*. A robot is never in space its map does not
know, so in **trinary** mode a pixel whose 8-bit grey (Jazzy's ``g``) is the saver's unknown grey
(205; with ``negate: 1`` its mirror 50, which has the same ``occ``) and which Nav2 reads as FREE is
UNKNOWN instead; their number is given in a warning. Nothing else changes: no other shade, no
scale or raw image (scale marks unknown by transparency, raw by 255). ``nav2``, ``nav2-jazzy`` and
``nav2-humble`` keep Nav2's reading exactly.

**Orientation.** :attr:`OccupancyMap.pixels` keeps the image's order: row 0 is the image's top row,
the largest y (Nav2 flips it into ``OccupancyGrid.data``, whose row 0 is the bottom).
:attr:`OccupancyMap.frame` is Nav2's ``origin``, the pose of the lower-left corner of the bottom-left
pixel; pixel ``(i, j)`` of an image ``H`` pixels high has its centre at
``frame.to_map((j + 0.5) res, (H - i - 0.5) res)`` (:meth:`OccupancyMap.pixel_centre`).

**Region masks** (:func:`load_region_mask`): a second map YAML + image in the Nav2 costmap-filter
style, with the map's size, resolution and origin. Nav2's filters see the cell values its map server
publishes for the mask, and so does beliefloc: with ``mode: raw`` a pixel painted grey ``k`` (0..100)
reads ``k``, the number of its region; 101..255 read -1 (no region). Paint rooms 1, 2, 3... in an
8-bit grey image and keep ``mode: raw``.

**Guards.** The YAML may be at most :data:`MAX_YAML_BYTES`, the image file :data:`MAX_IMAGE_BYTES`
and the image :data:`MAX_PIXELS` pixels -- checked from the header, before anything is decoded.
Only the formats in :data:`IMAGE_FORMATS` are opened; files are read whole and closed at once.
"""

from __future__ import annotations

import enum
import hashlib
import io
import math
import struct
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any

import numpy as np
from PIL import Image, UnidentifiedImageError
from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, field_validator, model_validator

from beliefloc.errors import FieldError, OccupancyMapError
from beliefloc.model import MapFrame
from beliefloc.source import Source, format_path, read_source, validate_source

MAX_PIXELS = 50_000_000
"""The largest image read: 50 million pixels (7071 x 7071, a 350 m square at 5 cm per pixel)."""
MAX_IMAGE_BYTES = 8 * MAX_PIXELS
"""The largest image file read (400 MB: the MAX_PIXELS-pixel image uncompressed at 16-bit RGBA)."""
MAX_YAML_BYTES = 1 << 20
"""The largest map YAML read (1 MiB; map_saver writes seven lines)."""
IMAGE_FORMATS = ("PPM", "PNG", "BMP", "TIFF", "GIF", "JPEG")
"""Pillow's names of the formats opened (PPM covers PGM and PBM); never one that runs a program."""

_FULL = 65535
"""GraphicsMagick's MaxRGB in its 16-bit build: the quantum of a full channel."""
_Q8 = 257
"""An 8-bit channel value times this is its 16-bit quantum (255 -> 65535)."""
SAVER_UNKNOWN_GREY = 205
"""The grey ``map_saver`` writes for unknown space in trinary mode (8-bit)."""
_READING = "beliefloc.semantic_map.occupancy_map/2"
"""Changes when the reading rules change, so that a cache keyed on :attr:`OccupancyMap.sha256` misses."""


class Nav2Version(str, enum.Enum):
    """The Nav2 release whose ``nav2_map_server/src/map_io.cpp`` a rule transcribes (see the module's
    docstring for what differs)."""

    HUMBLE = "humble"
    """The per-pixel loop (Humble, and every release before the Eigen rewrite)."""
    JAZZY = "jazzy"
    """The Eigen version: the current LTS."""


class OccupancyRule(str, enum.Enum):
    """How a map's image is read: which Nav2 release, and whether the saver's grey is unknown."""

    BELIEFLOC = "beliefloc"
    """Nav2 Jazzy's reading, except that the saver's unknown grey is UNKNOWN where Nav2 says FREE."""
    NAV2_HUMBLE = "nav2-humble"
    """Nav2 Humble's reading, as it is."""
    NAV2_JAZZY = "nav2-jazzy"
    """Nav2 Jazzy's reading, as it is. The map file's ``nav2`` names it (the current LTS)."""

    @classmethod
    def _missing_(cls, value: object) -> OccupancyRule | None:
        return cls.NAV2_JAZZY if value == NAV2_CURRENT else None

    @property
    def nav2(self) -> Nav2Version:
        """The Nav2 release whose reading this rule follows (or starts from)."""
        return Nav2Version.HUMBLE if self is OccupancyRule.NAV2_HUMBLE else Nav2Version.JAZZY


NAV2_CURRENT = "nav2"
"""The rule name that means the current Nav2 LTS: ``OccupancyRule("nav2")`` is
:attr:`OccupancyRule.NAV2_JAZZY` (it meant Humble's reading before both were named; see docs/map-format.md)."""
RULE_NAMES = (
    OccupancyRule.BELIEFLOC.value,
    NAV2_CURRENT,
    OccupancyRule.NAV2_HUMBLE.value,
    OccupancyRule.NAV2_JAZZY.value,
)
"""Every name a map file's ``occupancy_rule`` takes."""


class Occupancy(enum.IntEnum):
    """What a pixel of an occupancy map is, for beliefloc."""

    FREE = 0
    OCCUPIED = 1
    UNKNOWN = 2


MAX_RESOLUTION = 1000.0
"""Metres per pixel at most (a kilometre): ``resolution: 1e300`` is refused on its own line, not
blamed on ``grid.cell_size`` with two 300-digit numbers."""


class MapMode(str, enum.Enum):
    """Nav2's ``mode``: how a pixel's shade becomes an occupancy."""

    TRINARY = "trinary"
    SCALE = "scale"
    RAW = "raw"


# --- the YAML ------------------------------------------------------------------------------------


def _no_bool(value: Any) -> Any:
    """yaml-cpp does not read ``true`` as a number; pydantic would (as 1.0)."""
    if isinstance(value, bool):
        raise ValueError(f"should be a number, got {str(value).lower()}")
    return value


def _negate(value: Any) -> Any:
    """Nav2 reads ``negate`` as an int, else as a bool; beliefloc takes 0, 1, true and false."""
    if isinstance(value, bool):
        return int(value)
    if isinstance(value, (int, float)) and value in (0, 1):
        return int(value)
    raise ValueError(f"should be 0 or 1 (or false / true), got {value!r}")


def _lower(value: Any) -> Any:
    return value.lower() if isinstance(value, str) else value  # Nav2 lower-cases the mode


_Finite = Annotated[float, BeforeValidator(_no_bool), Field(allow_inf_nan=False)]
_Yaw = Annotated[float, BeforeValidator(_no_bool)]  # NaN allowed here: read as 0 with a warning
_Threshold = Annotated[float, BeforeValidator(_no_bool), Field(ge=0.0, le=1.0, allow_inf_nan=False)]


class MapYaml(BaseModel):
    """A ROS/Nav2 map YAML, validated.

    ``extra="ignore"``, not the project's usual ``"forbid"``: Nav2 reads only these keys and ignores
    any other, so a map that Nav2 loads must load here too (tools do add keys); the loader warns
    about each ignored key instead, so a misspelt optional ``mode`` does not pass unseen."""

    model_config = ConfigDict(frozen=True, extra="ignore")

    image: str
    resolution: Annotated[float, BeforeValidator(_no_bool), Field(gt=0.0, le=MAX_RESOLUTION, allow_inf_nan=False)]
    origin: tuple[_Finite, _Finite, _Yaw]
    negate: Annotated[int, BeforeValidator(_negate)]
    occupied_thresh: _Threshold
    free_thresh: _Threshold
    mode: Annotated[MapMode, BeforeValidator(_lower)] = MapMode.TRINARY

    @field_validator("image")
    @classmethod
    def _image_named(cls, value: str) -> str:
        if not value:
            raise ValueError("should name the image file (a PGM, PNG or BMP beside this YAML)")
        return value

    @field_validator("origin", mode="before")
    @classmethod
    def _three(cls, value: Any) -> Any:
        if not isinstance(value, (list, tuple)) or len(value) != 3:
            got = f"{len(value)} values" if isinstance(value, (list, tuple)) else repr(value)
            raise ValueError(f"should be three numbers [x, y, yaw] (metres, metres, radians), got {got}")
        return value

    @model_validator(mode="after")
    def _consistent(self) -> MapYaml:
        if math.isinf(self.origin[2]):
            raise FieldError(("origin", 2), f"the yaw should be a finite number of radians, got {self.origin[2]}")
        if not self.free_thresh < self.occupied_thresh:
            raise FieldError(
                ("free_thresh",),
                f"should be less than occupied_thresh ({self.occupied_thresh:g}), got {self.free_thresh:g}",
            )
        return self

    @property
    def frame(self) -> MapFrame:
        """The origin as a :class:`MapFrame` (a NaN yaw read as 0)."""
        x, y, yaw = self.origin
        return MapFrame(x, y, 0.0 if math.isnan(yaw) else yaw)


# --- the result ----------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class OccupancyMap:
    """An occupancy map as beliefloc reads it; see the module's docstring for the rules."""

    yaml_path: Path
    image_path: Path
    resolution: float
    """Metres per pixel."""
    frame: MapFrame
    """Nav2's ``origin``: the pose of the lower-left corner of the bottom-left pixel."""
    pixels: np.ndarray
    """``pixels[i, j]``: the :class:`Occupancy` (uint8) of image row ``i`` (0 = top, the largest y),
    column ``j``; shape ``(height, width)``; read-only."""
    sha256: str
    """Of the YAML's bytes, the image's bytes, the rule and the reading rules' version: a cache key."""
    warnings: tuple[str, ...] = ()
    rule: OccupancyRule = OccupancyRule.BELIEFLOC

    def __post_init__(self) -> None:
        pixels = self.pixels
        if not isinstance(pixels, np.ndarray) or pixels.ndim != 2 or pixels.dtype != np.uint8 or pixels.size == 0:
            raise ValueError("OccupancyMap.pixels must be a non-empty 2-D uint8 array")
        if int(pixels.max()) > max(Occupancy):
            raise ValueError(f"OccupancyMap.pixels holds {int(pixels.max())}, not an Occupancy")
        if not (math.isfinite(self.resolution) and self.resolution > 0):
            raise ValueError(f"OccupancyMap.resolution must be > 0, got {self.resolution}")
        frozen = pixels.view()
        frozen.flags.writeable = False
        object.__setattr__(self, "pixels", frozen)

    @property
    def height(self) -> int:
        """Pixels from top to bottom (image rows)."""
        return int(self.pixels.shape[0])

    @property
    def width(self) -> int:
        """Pixels from left to right (image columns)."""
        return int(self.pixels.shape[1])

    @property
    def size_m(self) -> tuple[float, float]:
        """``(width, height)`` in metres: along the map's x and y before the origin's yaw."""
        return self.width * self.resolution, self.height * self.resolution

    def blocked(self) -> np.ndarray:
        """``blocked[i, j]``: the pixel is occupied or unknown -- what stops a ray and what the robot
        cannot stand on. Read-only bool array, computed once."""
        cached: np.ndarray | None = self.__dict__.get("_blocked")
        if cached is None:
            cached = self.pixels != Occupancy.FREE
            cached.flags.writeable = False
            self.__dict__["_blocked"] = cached  # a cache, not state: bypasses the frozen __setattr__
        return cached

    def pixel_centre(self, row: np.ndarray | int, col: np.ndarray | int) -> tuple[np.ndarray, np.ndarray]:
        """Map-frame metres of the centre of pixel ``(row, col)`` (row 0 at the top)."""
        gx = (np.asarray(col, dtype=np.float64) + 0.5) * self.resolution
        gy = (self.height - np.asarray(row, dtype=np.float64) - 0.5) * self.resolution
        return self.frame.to_map(gx, gy)


# --- the pure core: channels -> Nav2's values and beliefloc's classes -------------------------------


def pixel_shade(colour: np.ndarray, alpha: np.ndarray | None, *, with_alpha: bool) -> np.ndarray:
    """Humble: ``shade[i, j] = mean(q_R, q_G, q_B [, A]) / 65535`` in [0, 1], as its loop computes it.

    ``colour[i, j, c]``: 16-bit quanta, ``c`` one grey channel (counted as R = G = B) or R, G, B;
    ``alpha[i, j]``: 16-bit alpha (65535 opaque) or None; ``with_alpha``: average it in (trinary)."""
    total: np.ndarray = colour.sum(axis=2, dtype=np.float64)
    if colour.shape[2] == 1:
        total *= 3.0
    count = 3.0
    if with_alpha and alpha is not None:
        total += alpha
        count = 4.0
    shade: np.ndarray = (total / count) / float(_FULL)
    return shade


def jazzy_grey(colour: np.ndarray) -> np.ndarray:
    """Jazzy: ``grey[i, j]`` in 0..255 (uint8), the 8-bit intensity GraphicsMagick hands Nav2.

    ``gray.type(GrayscaleType)`` turns a colour pixel into its Rec. 601 luma in GraphicsMagick's
    integer form, ``(306 q_R + 601 q_G + 117 q_B) >> 10`` (``PixelIntensityRec601`` for a 16-bit
    quantum; a grey pixel keeps its value, 306 + 601 + 117 = 1024), and ``write(..., "I",
    CharPixel)`` cuts the quantum to 8 bits, ``q / 257`` truncated (``ScaleQuantumToChar``): a 16-bit
    image loses its low byte before any threshold."""
    quantum: np.ndarray
    if colour.shape[2] == 1:
        quantum = colour[..., 0].astype(np.uint32)
    else:
        q = colour.astype(np.uint32)
        quantum = (q[..., 0] * 306 + q[..., 1] * 601 + q[..., 2] * 117) >> 10
    grey: np.ndarray = (quantum // _Q8).astype(np.uint8)
    return grey


def _half_away_from_zero(x: np.ndarray) -> np.ndarray:
    """``std::round`` (Eigen's ``round()``) in the array's own precision: halves away from zero."""
    magnitude = np.abs(x)
    whole = np.floor(magnitude)
    rounded = whole + (magnitude - whole >= 0.5)  # the difference is exact in float32
    result: np.ndarray = np.copysign(rounded, x)
    return result


@dataclass(frozen=True)
class _Reading:
    """One rule's reading of an image: Nav2's cell values and beliefloc's classes, and the grey Nav2
    compared (for the saver's grey)."""

    values: np.ndarray
    """int16 -1..100: the ``OccupancyGrid`` cell of each pixel (image order)."""
    occupied: np.ndarray
    free: np.ndarray
    """bool masks; neither: UNKNOWN."""
    saver_grey: np.ndarray | None
    """bool: the pixel is the saver's unknown grey as this Nav2 reads it (trinary only), else None."""


def _read_humble(colour: np.ndarray, alpha: np.ndarray | None, params: MapYaml) -> _Reading:
    """Nav2 Humble's ``loadMapFromFile`` loop, vectorised: the mean of the 16-bit channels (alpha
    averaged in by trinary), strict thresholds (``occupied_thresh < occ``, ``occ < free_thresh``)
    in float64; scale: not fully opaque -> -1, in between ``std::rint`` (half to even); raw:
    ``std::round(255 shade)``, alpha ignored."""
    shape = colour.shape[:2]
    if params.mode is MapMode.RAW:
        percent = np.floor(pixel_shade(colour, None, with_alpha=False) * 255.0 + 0.5)  # std::round, >= 0
        known = percent <= 100.0
        values = np.where(known, percent, -1.0).astype(np.int16)
        # beliefloc's reading of a raw percentage p = v / 100, with Humble's strict comparisons
        occupied = known & (percent / 100.0 > params.occupied_thresh)
        free = known & (percent / 100.0 < params.free_thresh)
        return _Reading(values, occupied, free, None)
    shade = pixel_shade(colour, alpha, with_alpha=params.mode is MapMode.TRINARY)
    occ = shade if params.negate else 1.0 - shade
    occupied = occ > params.occupied_thresh
    free = occ < params.free_thresh
    values = np.full(shape, -1, dtype=np.int16)
    if params.mode is MapMode.SCALE:
        between = (occ - params.free_thresh) / (params.occupied_thresh - params.free_thresh) * 100.0
        values = np.clip(np.rint(between), 0.0, 100.0).astype(np.int16)  # in between: 0..100
    values[occupied] = 100
    values[free] = 0
    saver_grey = None
    if params.mode is MapMode.SCALE:
        if alpha is not None:
            opaque = alpha == _FULL
            values[~opaque] = -1
            occupied &= opaque
            free &= opaque
    else:
        grey = (255 - SAVER_UNKNOWN_GREY if params.negate else SAVER_UNKNOWN_GREY) * _Q8
        saver_grey = np.all(colour == grey, axis=2)
    return _Reading(values, occupied, free, saver_grey)


def _read_jazzy(colour: np.ndarray, alpha: np.ndarray | None, params: MapYaml) -> _Reading:
    """Nav2 Jazzy's ``loadMapFromFile`` (the Eigen version), transcribed: one 8-bit grey per pixel
    (:func:`jazzy_grey`); trinary and scale: ``occ = grey / 255`` in float32 (``1 - `` it unless
    ``negate``), inclusive thresholds in float32 (``occ >= occupied_thresh`` -> 100, then
    ``occ <= free_thresh`` -> 0), scale: strictly between them ``round(100 (occ - free) / (occupied
    - free))`` in float32, halves away from zero; then every pixel whose 8-bit alpha is below 255
    -> -1, in trinary and scale alike. Raw: the grey itself if at most 100, else -1 (alpha
    ignored)."""
    grey = jazzy_grey(colour)
    if params.mode is MapMode.RAW:
        known = grey <= 100
        values = np.where(known, grey.astype(np.int16), np.int16(-1)).astype(np.int16)
        # beliefloc's reading of a raw percentage p = v / 100, with Jazzy's inclusive comparisons
        percent = grey.astype(np.float64) / 100.0
        return _Reading(
            values, known & (percent >= params.occupied_thresh), known & (percent <= params.free_thresh), None
        )
    occ = grey.astype(np.float32) / np.float32(255.0)
    if not params.negate:
        occ = np.float32(1.0) - occ
    occupied_thresh, free_thresh = np.float32(params.occupied_thresh), np.float32(params.free_thresh)
    occupied = occ >= occupied_thresh
    free = occ <= free_thresh
    values = np.full(grey.shape, -1, dtype=np.int16)
    values[occupied] = 100
    values[free] = 0
    if params.mode is MapMode.SCALE:
        between = (occ > free_thresh) & (occ < occupied_thresh)
        span = np.float32(params.occupied_thresh - params.free_thresh)  # a double difference, then float
        scaled = ((occ - free_thresh) / span) * np.float32(100.0)
        values[between] = _half_away_from_zero(scaled[between]).astype(np.int16)
    if alpha is not None:
        transparent = (alpha // _Q8) < 255
        values[transparent] = -1
        occupied &= ~transparent
        free &= ~transparent
    saver = 255 - SAVER_UNKNOWN_GREY if params.negate else SAVER_UNKNOWN_GREY
    saver_grey = grey == saver if params.mode is MapMode.TRINARY else None
    return _Reading(values, occupied, free, saver_grey)


_READERS = {Nav2Version.HUMBLE: _read_humble, Nav2Version.JAZZY: _read_jazzy}


def nav2_cell_values(
    colour: np.ndarray, alpha: np.ndarray | None, params: MapYaml, version: Nav2Version = Nav2Version.JAZZY
) -> np.ndarray:
    """``value[i, j]`` in -1..100: the ``OccupancyGrid`` cell Nav2 ``version``'s map server publishes
    for image pixel ``(i, j)`` (row 0 at the top; Nav2 stores it at row ``H - 1 - i``). int16."""
    return _READERS[version](colour, alpha, params).values


def classify_pixels(
    colour: np.ndarray, alpha: np.ndarray | None, params: MapYaml, rule: OccupancyRule
) -> tuple[np.ndarray, int]:
    """``(pixels, reclassified)``: the :class:`Occupancy` (uint8) of every pixel by the module's
    table under ``rule``, and how many pixels of the saver's unknown grey the rule turned from FREE
    to UNKNOWN (only :attr:`OccupancyRule.BELIEFLOC` does)."""
    reading = _READERS[rule.nav2](colour, alpha, params)
    pixels = np.full(colour.shape[:2], Occupancy.UNKNOWN, dtype=np.uint8)
    pixels[reading.occupied] = Occupancy.OCCUPIED
    pixels[reading.free] = Occupancy.FREE
    if rule is not OccupancyRule.BELIEFLOC or reading.saver_grey is None:
        return pixels, 0
    saver_unknown = reading.saver_grey & reading.free
    pixels[saver_unknown] = Occupancy.UNKNOWN
    return pixels, int(np.count_nonzero(saver_unknown))


# --- the edge: files -----------------------------------------------------------------------------


def load_occupancy(path: str | Path, *, rule: OccupancyRule = OccupancyRule.BELIEFLOC) -> OccupancyMap:
    """Read a ROS/Nav2 map YAML and its image; see the module's docstring for every rule.

    Raises :class:`OccupancyMapError` naming the YAML file, line and field (for an image problem,
    the image file and the ``image`` line). :attr:`OccupancyMap.warnings` says what was read
    differently from what was written (ignored keys, a NaN yaw, the saver's unknown grey)."""
    source, params, notes = _read_yaml(path)
    image_path = _image_path(source, params)
    raw, colour, alpha = _read_image(image_path, source)
    pixels, reclassified = classify_pixels(colour, alpha, params, rule)
    if reclassified:
        grey = 255 - SAVER_UNKNOWN_GREY if params.negate else SAVER_UNKNOWN_GREY
        occ = 1.0 - SAVER_UNKNOWN_GREY / 255.0
        notes.append(
            f"{reclassified} pixels of map_saver's unknown grey {grey} read as unknown, not free as Nav2 reads "
            f"them (occ {occ:.3f} <= free_thresh {params.free_thresh:g}); occupancy_rule: nav2 in the map file "
            "keeps Nav2's reading"
        )
    digest = hashlib.sha256()
    for part in (_READING, source.sha256, hashlib.sha256(raw).hexdigest(), rule.value):
        digest.update(part.encode() + b"\n")
    return OccupancyMap(
        yaml_path=source.path,
        image_path=image_path,
        resolution=params.resolution,
        frame=params.frame,
        pixels=pixels,
        sha256=digest.hexdigest(),
        warnings=tuple(notes),
        rule=rule,
    )


def load_region_mask(path: str | Path, like: OccupancyMap) -> np.ndarray:
    """``region[i, j]``: the value Nav2's map server publishes for pixel ``(i, j)`` of a region mask,
    read as the Nav2 release ``like``'s rule follows reads it (row 0 at the top, int16 in -1..100);
    with ``mode: raw`` the grey value painted, 1..100 (101..255
    read -1). The mask must have the size, resolution and origin of ``like``: else an
    :class:`OccupancyMapError` names both files and the field that differs."""
    source, params, _ = _read_yaml(path)
    why = f"a region mask must have the size, resolution and origin of its map {like.yaml_path}"
    if not math.isclose(params.resolution, like.resolution, rel_tol=1e-9, abs_tol=0.0):
        raise source.error(
            ("resolution",),
            f"{params.resolution:g} differs from the map's {like.resolution:g}; {why}",
            OccupancyMapError,
        )
    mine, theirs = params.frame, like.frame
    for index, name, a, b in ((0, "x", mine.x, theirs.x), (1, "y", mine.y, theirs.y), (2, "yaw", mine.yaw, theirs.yaw)):
        if not math.isclose(a, b, rel_tol=1e-9, abs_tol=1e-9):
            raise source.error(
                ("origin", index), f"{name} {a:g} differs from the map's {b:g}; {why}", OccupancyMapError
            )
    image_path = _image_path(source, params)
    _, colour, alpha = _read_image(image_path, source, size=(like.width, like.height), size_of=like.image_path, why=why)
    return nav2_cell_values(colour, alpha, params, like.rule.nav2)


def _read_yaml(path: str | Path) -> tuple[Source, MapYaml, list[str]]:
    """The validated YAML and the warnings about it (keys Nav2 ignores, a NaN yaw)."""
    file_path = Path(path)
    size = file_path.stat().st_size if file_path.is_file() else 0  # else read_source says what it is
    if size > MAX_YAML_BYTES:
        raise OccupancyMapError(
            f"{file_path}: {size:,} bytes is more than a map YAML's limit of {MAX_YAML_BYTES:,} bytes; "
            "is this the map's YAML (image:, resolution:, origin:, ...)?"
        )
    source = read_source(file_path, OccupancyMapError)
    if not isinstance(source.data, dict):
        raise OccupancyMapError(
            f"{source.path}:1:1: a map YAML is a mapping (image:, resolution:, origin:, negate:, occupied_thresh:, "
            "free_thresh:, mode:), as map_saver writes it"
        )
    params = validate_source(source, MapYaml, OccupancyMapError)
    notes: list[str] = []
    known = sorted(MapYaml.model_fields)
    for key in source.data:
        if key not in MapYaml.model_fields:
            notes.append(
                f"{_where(source, (str(key),), key=True)}: unknown key {key!r} ignored (Nav2 ignores it too); "
                f"the keys read are: {', '.join(known)}"
            )
    if math.isnan(params.origin[2]):
        notes.append(f"{_where(source, ('origin', 2))}: the yaw is NaN; read as 0 (no rotation)")
    return source, params, notes


def _where(source: Source, path: tuple[str | int, ...], *, key: bool = False) -> str:
    """``line 3, column 9: origin[2]`` -- a warning's place; the caller names the file."""
    found, (line, column) = source.locate(path, key=key)
    return f"line {line}, column {column}: {format_path(found)}"


def _image_path(source: Source, params: MapYaml) -> Path:
    """``image`` relative to the YAML's folder (as Nav2: ``dirname(yaml) + '/' + image``) or absolute."""
    named = Path(params.image)
    return named if named.is_absolute() else source.path.parent / named


class _Unsupported(Exception):
    """An image Pillow decodes but in a pixel mode this module does not read."""


_PILLOW_ERRORS = (OSError, SyntaxError, ValueError, EOFError, IndexError, struct.error)
"""What Pillow raises on a broken or unsupported file (UnidentifiedImageError is an OSError)."""


def _read_image(
    image_path: Path,
    source: Source,
    *,
    size: tuple[int, int] | None = None,
    size_of: Path | None = None,
    why: str = "",
) -> tuple[bytes, np.ndarray, np.ndarray | None]:
    """The image's bytes, its colour quanta ``(H, W, 1 or 3)`` and alpha quanta ``(H, W)`` or None.

    Every failure is an :class:`OccupancyMapError` at the YAML's ``image`` line naming the image.
    With ``size`` (width, height), an image of another size is refused before it is decoded."""

    def fail(problem: str) -> OccupancyMapError:
        return OccupancyMapError(source.format(("image",), f"{image_path}: {problem}"))

    if not image_path.exists():
        raise fail("no such file (a relative image is read from the YAML's folder)")
    if not image_path.is_file():
        raise fail("is not a regular file")
    length = image_path.stat().st_size
    if length > MAX_IMAGE_BYTES:
        raise fail(f"{length:,} bytes is more than the limit of {MAX_IMAGE_BYTES:,} bytes for a map image")
    try:
        raw = image_path.read_bytes()
    except OSError as exc:
        raise fail(f"cannot be read ({exc.strerror})") from None
    problem: str | None = None
    decoded: tuple[np.ndarray, np.ndarray | None] | None = None
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", Image.DecompressionBombWarning)  # MAX_PIXELS is lower
            with Image.open(io.BytesIO(raw), formats=IMAGE_FORMATS) as image:
                width, height = image.size
                problem = image_size_problem(width, height)
                if problem is None and size is not None and (width, height) != size:
                    problem = f"is {width} x {height} pixels, the map's image {size_of} {size[0]} x {size[1]}; {why}"
                if problem is None:
                    image.load()
                    decoded = _channels(image)
    except Image.DecompressionBombError:
        raise fail(f"has more than the limit of {MAX_PIXELS:,} pixels") from None
    except UnidentifiedImageError:
        formats = ", ".join(IMAGE_FORMATS)
        raise fail(f"is not an image in a format beliefloc reads ({formats}; PPM covers PGM)") from None
    except _Unsupported as exc:
        raise fail(str(exc)) from None
    except _PILLOW_ERRORS as exc:
        raise fail(f"cannot be read as an image ({exc})") from None
    if decoded is None:
        raise fail(problem or "has no pixels")
    return raw, *decoded


def image_size_problem(width: int, height: int) -> str | None:
    """What is wrong with an image of ``width x height`` pixels, or None: no pixels, or more than
    :data:`MAX_PIXELS`. Checked from the header, before decoding."""
    if width <= 0 or height <= 0:
        return f"is {width} x {height} pixels: a map needs at least one"
    if width * height > MAX_PIXELS:
        return f"is {width} x {height} = {width * height:,} pixels, more than the limit of {MAX_PIXELS:,} pixels"
    return None


def _channels(image: Image.Image) -> tuple[np.ndarray, np.ndarray | None]:
    """16-bit colour quanta ``(H, W, 1 or 3)`` and alpha ``(H, W)`` (or None), as GraphicsMagick sees
    the pixels: a palette becomes its colours, a transparent colour (``tRNS``) an alpha channel."""
    mode = image.mode
    if "transparency" in image.info and mode in ("1", "L", "P", "RGB"):
        image = image.convert("RGBA")
    elif mode in ("1", "P", "PA", "La", "RGBa", "RGBX"):
        image = image.convert({"1": "L", "P": "RGB", "PA": "RGBA", "La": "LA", "RGBa": "RGBA", "RGBX": "RGB"}[mode])
    mode = image.mode
    height, width = image.size[1], image.size[0]
    if mode in ("L", "LA", "RGB", "RGBA"):
        values = np.asarray(image, dtype=np.uint8).reshape(height, width, -1).astype(np.uint16) * np.uint16(_Q8)
        if mode.endswith("A"):
            return values[..., :-1], values[..., -1]
        return values, None
    if mode.startswith("I;16") or (mode == "I" and image.format in ("PPM", "PNG")):
        # 16-bit grey; Pillow has scaled a PGM's maxval to 0..65535
        values32 = np.asarray(image).astype(np.int64)
        if values32.size and (values32.min() < 0 or values32.max() > _FULL):
            raise _Unsupported("has grey values outside 0..65535")
        return values32.astype(np.uint16).reshape(height, width, 1), None
    raise _Unsupported(
        f"has pixel mode {mode}, which beliefloc does not read; save the map as 8-bit grey (what map_saver "
        "writes), 16-bit grey, RGB or RGBA"
    )
