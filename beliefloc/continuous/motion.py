"""The odometry motion model of a differential-drive base, sampled and on the grid.

Probabilistic Robotics (Thrun, Burgard & Fox 2005), Table 5.6 ``sample_motion_model_odometry``, as
Nav2's AMCL implements it (``nav2_amcl/src/motion_model/differential_motion_model.cpp``). An odometry
*delta* ``(dx, dy, dyaw)`` is the motion measured by the wheels, expressed in the robot frame at the
start of the motion (REP 103: x forward, y left, yaw counter-clockwise). It is decomposed into a
first turn, a straight translation and a second turn::

    trans = hypot(dx, dy)
    rot1  = atan2(dy, dx)    (0 when trans < MIN_TRANSLATION: a turn in place)
    rot2  = dyaw - rot1

and each part is disturbed by zero-mean Gaussian noise whose variance grows with the motion::

    var(rot1)  = alpha1 * rot1'^2 + alpha2 * trans^2
    var(trans) = alpha3 * trans^2 + alpha4 * (rot1'^2 + rot2'^2)
    var(rot2)  = alpha1 * rot2'^2 + alpha2 * trans^2

where ``rot'`` is the smaller of ``|rot|`` and ``|pi - |rot||`` (AMCL's choice: driving backwards is
a half turn in ``rot1`` but should not be that noisy). The pose after the motion, from ``(x, y, yaw)``::

    x'   = x + trans_hat * cos(yaw + rot1_hat)
    y'   = y + trans_hat * sin(yaw + rot1_hat)
    yaw' = yaw + rot1_hat + rot2_hat

:func:`sample_odometry` draws that for many poses at once. :func:`predict_grid` is the same model for
a belief over a grid of cells × headings: for every heading, the belief image is shifted by the
heading's displacement and blurred by the noise (separable 1-D kernels; Fox, Burgard & Thrun's grid
Markov localization), then moved across headings by the turn and blurred by the turn's noise.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy import special

from beliefloc.model import wrap_angle

MIN_TRANSLATION = 0.01
"""Below this translation (metres) ``rot1`` is 0: a turn in place (AMCL: ``delta_trans < 0.01``)."""


@dataclass(frozen=True)
class OdometryNoise:
    """AMCL's ``alpha1``..``alpha4`` for the differential drive (Nav2's defaults: 0.2 each).

    Each is a dimensionless variance factor of Probabilistic Robotics Table 5.6: the variance of a
    part of the motion is the sum of the named squares times the factors."""

    alpha1: float = 0.2
    """Rotation noise from rotation: ``var(rot) += alpha1 * rot^2`` (rad² per rad²)."""
    alpha2: float = 0.2
    """Rotation noise from translation: ``var(rot) += alpha2 * trans^2`` (rad² per m²)."""
    alpha3: float = 0.2
    """Translation noise from translation: ``var(trans) += alpha3 * trans^2`` (m² per m²)."""
    alpha4: float = 0.2
    """Translation noise from rotation: ``var(trans) += alpha4 * (rot1^2 + rot2^2)`` (m² per rad²)."""

    def __post_init__(self) -> None:
        for name in ("alpha1", "alpha2", "alpha3", "alpha4"):
            value = getattr(self, name)
            if not (math.isfinite(value) and 0.0 <= value <= 10.0):
                raise ValueError(f"OdometryNoise.{name} must be a number in [0, 10], got {value}")


@dataclass(frozen=True)
class OdometryParts:
    """An odometry delta as Table 5.6's three parts and their noise (standard deviations)."""

    rot1: float
    trans: float
    rot2: float
    sd_rot1: float
    sd_trans: float
    sd_rot2: float


def odometry_parts(delta: tuple[float, float, float], noise: OdometryNoise) -> OdometryParts:
    """``delta = (dx, dy, dyaw)`` in the robot frame at the start -> :class:`OdometryParts`."""
    dx, dy, dyaw = (float(v) for v in delta)
    trans = math.hypot(dx, dy)
    rot1 = math.atan2(dy, dx) if trans >= MIN_TRANSLATION else 0.0
    rot2 = float(wrap_angle(dyaw - rot1))

    def reduced(angle: float) -> float:
        return min(abs(angle), abs(math.pi - abs(angle)))

    r1, r2 = reduced(rot1), reduced(rot2)
    var_rot1 = noise.alpha1 * r1**2 + noise.alpha2 * trans**2
    var_trans = noise.alpha3 * trans**2 + noise.alpha4 * (r1**2 + r2**2)
    var_rot2 = noise.alpha1 * r2**2 + noise.alpha2 * trans**2
    return OdometryParts(rot1, trans, rot2, math.sqrt(var_rot1), math.sqrt(var_trans), math.sqrt(var_rot2))


def compose(poses: np.ndarray, delta: np.ndarray | tuple[float, float, float]) -> np.ndarray:
    """``poses ⊕ delta``: each pose ``(x, y, yaw)`` (shape ``(N, 3)``) moved by ``delta`` (shape
    ``(3,)`` or ``(N, 3)``) given in its own frame. A new ``(N, 3)`` array, yaws wrapped to (-pi, pi]."""
    p = np.asarray(poses, dtype=np.float64).reshape(-1, 3)
    d = np.broadcast_to(np.asarray(delta, dtype=np.float64), p.shape)
    c, s = np.cos(p[:, 2]), np.sin(p[:, 2])
    out = np.empty_like(p)
    out[:, 0] = p[:, 0] + c * d[:, 0] - s * d[:, 1]
    out[:, 1] = p[:, 1] + s * d[:, 0] + c * d[:, 1]
    out[:, 2] = wrap_angle(p[:, 2] + d[:, 2])
    return out


def relative(start: np.ndarray, end: np.ndarray) -> np.ndarray:
    """``start ⊖ end``: the delta ``(dx, dy, dyaw)`` in ``start``'s frame that moves ``start`` to
    ``end`` (the inverse of :func:`compose`). Shapes ``(N, 3)`` or ``(3,)``; returns the same shape."""
    a = np.asarray(start, dtype=np.float64)
    b = np.asarray(end, dtype=np.float64)
    ex, ey = b[..., 0] - a[..., 0], b[..., 1] - a[..., 1]
    c, s = np.cos(a[..., 2]), np.sin(a[..., 2])
    return np.stack([c * ex + s * ey, -s * ex + c * ey, wrap_angle(b[..., 2] - a[..., 2])], axis=-1)


def sample_odometry(
    poses: np.ndarray,
    delta: tuple[float, float, float] | np.ndarray,
    noise: OdometryNoise,
    rng: np.random.Generator,
) -> np.ndarray:
    """Probabilistic Robotics Table 5.6 for every pose: ``poses (N, 3)`` ``[x, y, yaw]`` moved by the
    odometry ``delta = (dx, dy, dyaw)`` (robot frame at the start) with noise drawn from ``rng``,
    independently per pose. Returns a new ``(N, 3)`` array (yaws in (-pi, pi])."""
    p = np.asarray(poses, dtype=np.float64).reshape(-1, 3)
    parts = odometry_parts((float(delta[0]), float(delta[1]), float(delta[2])), noise)
    n = p.shape[0]
    rot1 = parts.rot1 - rng.normal(0.0, 1.0, n) * parts.sd_rot1
    trans = parts.trans - rng.normal(0.0, 1.0, n) * parts.sd_trans
    rot2 = parts.rot2 - rng.normal(0.0, 1.0, n) * parts.sd_rot2
    heading = p[:, 2] + rot1
    out = np.empty_like(p)
    out[:, 0] = p[:, 0] + trans * np.cos(heading)
    out[:, 1] = p[:, 1] + trans * np.sin(heading)
    out[:, 2] = wrap_angle(heading + rot2)
    return out


# --- on the grid ---------------------------------------------------------------------------------

MIN_BLUR_CELLS = 0.05
"""The smallest standard deviation of a grid kernel, in cells (a noiseless motion still spreads a
cell's mass over the cells its region reaches)."""
KERNEL_TAIL = 1e-6
"""Kernel weights below this fraction of the kernel's mass are dropped (then renormalised)."""
FFT_TAPS = 32
"""A 2-D kernel with more taps than this is applied by FFT, fewer by shifted adds (the two cost
the same at about 20-30 taps on a 120 x 160 image; a 0.5 m move on a 0.1 m pose lattice has ~200)."""
_REGION_SAMPLES = 16
"""Sub-positions across a source cell when a kernel is integrated (the state is the whole cell)."""


def region_kernel(shift: float, sigma: float) -> tuple[int, np.ndarray]:
    """``(first, weights)``: the 1-D kernel that moves mass from a cell to the cells ``first``,
    ``first + 1``, ... when the robot, anywhere in the cell (uniform), moves by ``shift`` cells with
    Gaussian noise of standard deviation ``sigma`` cells. ``weights`` sum to 1.

    ``w_i = mean_s [Phi((i + 1/2 - shift - s)/sigma) - Phi((i - 1/2 - shift - s)/sigma)]`` over
    sub-positions ``s`` of the source cell in (-1/2, 1/2): the cell-to-cell probability of the
    continuous motion. With ``sigma`` near 0 it is the linear split ``[1 - f, f]`` of a fractional shift."""
    sd = max(float(sigma), MIN_BLUR_CELLS)
    reach = math.ceil(4.0 * sd + 1.0)
    low, high = math.floor(shift) - reach, math.ceil(shift) + reach
    offsets = np.arange(low, high + 1, dtype=np.float64)
    subs = (np.arange(_REGION_SAMPLES) + 0.5) / _REGION_SAMPLES - 0.5
    centre = shift + subs[:, None]
    upper = special.ndtr((offsets[None, :] + 0.5 - centre) / sd)
    lower = special.ndtr((offsets[None, :] - 0.5 - centre) / sd)
    weights = (upper - lower).mean(axis=0)
    keep = np.flatnonzero(weights >= KERNEL_TAIL * weights.sum())
    weights = weights[keep[0] : keep[-1] + 1]
    return low + int(keep[0]), weights / weights.sum()


def region_kernel_2d(shift: tuple[float, float], cov: np.ndarray) -> tuple[tuple[int, int], np.ndarray]:
    """:func:`_region_kernel_2d`, remembered for the last :data:`KERNELS_KEPT` shifts and covariances:
    a commanded move asks for the same few kernels at every step (the depot's lattice: 40 yaws a
    prediction, a third of its time). The weights are read-only."""
    c = np.asarray(cov, dtype=np.float64)
    return _kept_kernel_2d(
        float(shift[0]), float(shift[1]), float(c[0, 0]), float(c[0, 1]), float(c[1, 0]), float(c[1, 1])
    )


KERNELS_KEPT = 1024
"""How many 2-D motion kernels :func:`region_kernel_2d` remembers."""


@lru_cache(maxsize=KERNELS_KEPT)
def _kept_kernel_2d(
    row: float, col: float, c00: float, c01: float, c10: float, c11: float
) -> tuple[tuple[int, int], np.ndarray]:
    first, weights = _region_kernel_2d((row, col), np.array([[c00, c01], [c10, c11]]))
    weights.setflags(write=False)
    return first, weights


def _region_kernel_2d(shift: tuple[float, float], cov: np.ndarray) -> tuple[tuple[int, int], np.ndarray]:
    """``((first_row, first_col), weights)``: the 2-D kernel that moves mass from a cell to the cells
    ``(first_row + i, first_col + j)`` with probability ``weights[i, j]`` when the robot, anywhere in
    the cell (uniform), moves by ``shift = (rows, cols)`` cells with Gaussian noise of covariance
    ``cov`` (2x2, in cells², axes rows then cols). ``weights`` sum to 1.

    A uniform point in the source cell, displaced, falls in the target cell with the probability
    of the displacement under the *tent* (bilinear) weight of the offset between the cells (the
    box of the source convolved with the box of the target): the Gaussian is sampled on a fine
    lattice and each sample's mass is split bilinearly over the four cells around it. A noiseless
    fractional shift is the linear split of a shifted image."""
    c = np.asarray(cov, dtype=np.float64) + np.eye(2) * MIN_BLUR_CELLS**2
    sd = np.sqrt(np.diag(c))
    step = float(min(0.125, sd.min() / 3.0))
    half = np.ceil(4.0 * sd / step)
    a = np.arange(-half[0], half[0] + 1) * step
    b = np.arange(-half[1], half[1] + 1) * step
    da, db = np.meshgrid(a, b, indexing="ij")
    inv = np.linalg.inv(c)
    mass = np.exp(-0.5 * (inv[0, 0] * da * da + 2 * inv[0, 1] * da * db + inv[1, 1] * db * db))
    pa, pb = da + shift[0], db + shift[1]
    fa, fb = np.floor(pa), np.floor(pb)
    ta, tb = pa - fa, pb - fb
    lo_a, lo_b = int(fa.min()), int(fb.min())
    rows, cols = int(fa.max()) - lo_a + 2, int(fb.max()) - lo_b + 2
    ia, ib = (fa - lo_a).astype(np.int64), (fb - lo_b).astype(np.int64)
    flat = np.zeros(rows * cols)
    for oa, wa in ((0, 1 - ta), (1, ta)):
        for ob, wb in ((0, 1 - tb), (1, tb)):
            np.add.at(flat, ((ia + oa) * cols + ib + ob).ravel(), (mass * wa * wb).ravel())
    kernel = flat.reshape(rows, cols)
    kernel /= kernel.sum()
    kernel[kernel < KERNEL_TAIL * kernel.max()] = 0.0
    nz_r, nz_c = np.nonzero(kernel)
    kernel = kernel[nz_r.min() : nz_r.max() + 1, nz_c.min() : nz_c.max() + 1]
    return (lo_a + int(nz_r.min()), lo_b + int(nz_c.min())), kernel / kernel.sum()


def _shift_add(
    out: np.ndarray, image: np.ndarray, offset: tuple[int, ...], weight: float, scratch: np.ndarray | None = None
) -> None:
    """``out[n + offset] += weight * image[n]`` over every index ``n`` where both are inside
    (mass moved off the array is lost). ``scratch`` (the shape of ``image``): room for the
    product, instead of a new array each time (the same numbers)."""
    dst: list[slice] = []
    src: list[slice] = []
    for size, o in zip(image.shape, offset, strict=True):
        if abs(o) >= size:
            return
        if o >= 0:
            dst.append(slice(o, None))
            src.append(slice(0, size - o))
        else:
            dst.append(slice(0, size + o))
            src.append(slice(-o, None))
    if scratch is None:
        out[tuple(dst)] += weight * image[tuple(src)]
        return
    source = image[tuple(src)]
    product = scratch[tuple(slice(0, n) for n in source.shape)]
    np.multiply(source, weight, out=product)
    out[tuple(dst)] += product


def _convolve_into(out: np.ndarray, image: np.ndarray, first: tuple[int, int], weights: np.ndarray) -> None:
    """``out[n + first + (i, j)] += weights[i, j] * image[n]`` for every tap at once: a linear
    convolution by real FFTs (:mod:`scipy.fft`; scipy.signal's ``fftconvolve`` does the same but
    takes most of a second to import), its rounding (~1e-17 of the largest value) clipped at 0 so
    that no mass is negative. Mass moved off the array is lost."""
    from scipy import fft

    shape = tuple(a + b - 1 for a, b in zip(image.shape, weights.shape, strict=True))
    padded = tuple(fft.next_fast_len(n, real=True) for n in shape)
    spectrum = fft.rfft2(image, padded) * fft.rfft2(weights, padded)
    full = fft.irfft2(spectrum, padded)[: shape[0], : shape[1]]
    np.maximum(full, 0.0, out=full)
    # out[m] = full[m - first] wherever both are inside
    dst, src = [], []
    for size, size_full, o in zip(out.shape, full.shape, first, strict=True):
        lo, hi = max(0, o), min(size, size_full + o)
        if lo >= hi:
            return
        dst.append(slice(lo, hi))
        src.append(slice(lo - o, hi - o))
    out[tuple(dst)] += full[tuple(src)]


def predict_grid(
    belief: np.ndarray,
    yaws: np.ndarray,
    cell_size: float,
    delta: tuple[float, float, float],
    noise: OdometryNoise,
    free: np.ndarray | None = None,
    *,
    normalize: bool = True,
) -> np.ndarray:
    """The belief after the odometry ``delta``: ``bel'(s') = sum_s p(s' | s, delta) bel(s)``.

    ``belief[k, r, c]``: heading ``k``, cell row ``r`` (0 at the top: the largest y), column ``c``;
    ``yaws[k]``: heading ``k``'s yaw in the *grid* frame (x along the columns, y up the rows),
    evenly spaced around the circle (either direction); ``cell_size`` in metres; ``free[r, c]``
    (optional): the cells the robot can be in -- mass moved elsewhere is dropped and the rest
    renormalised (a robot does not drive into walls); ``normalize=False`` keeps the mass as moved.

    Per heading ``k``: the displacement ``R(yaws[k]) (dx, dy)`` in cells and its covariance (the
    along-track variance ``sd_trans²`` and cross-track ``(trans sd_rot1)²`` of
    :func:`odometry_parts`, rotated to the direction of travel), as one :func:`region_kernel_2d`
    applied by shifted adds. Then across headings: the turn ``dyaw`` in heading steps with sd
    ``hypot(sd_rot1, sd_rot2)``, circularly (:func:`region_kernel`). Position and turn noise are
    treated as independent. A new array; the input is not changed. Loops run over headings and
    kernel taps, never over cells."""
    bel = np.asarray(belief)
    if bel.ndim != 3 or bel.shape[0] != len(yaws):
        raise ValueError(f"belief of shape {bel.shape} for {len(yaws)} headings; expected (headings, rows, cols)")
    headings = bel.shape[0]
    parts = odometry_parts(delta, noise)
    dx, dy, dyaw = (float(v) for v in delta)
    moved = np.zeros_like(bel)
    scratch = np.empty_like(bel[0]) if headings else None
    along, across = parts.sd_trans / cell_size, parts.trans * parts.sd_rot1 / cell_size
    for k in range(headings):
        yaw = float(yaws[k])
        c, s = math.cos(yaw), math.sin(yaw)
        gx, gy = c * dx - s * dy, s * dx + c * dy
        travel = yaw + parts.rot1
        # the direction of travel in (row, col) axes: rows grow downwards, y upwards
        u = np.array([-math.sin(travel), math.cos(travel)])
        w = np.array([math.cos(travel), math.sin(travel)])
        cov = along**2 * np.outer(u, u) + across**2 * np.outer(w, w)
        (first_r, first_c), weights = region_kernel_2d((-gy / cell_size, gx / cell_size), cov)
        if np.count_nonzero(weights) > FFT_TAPS:
            _convolve_into(moved[k], bel[k], (first_r, first_c), weights)
            continue
        for (i, j), weight in np.ndenumerate(weights):
            if weight > 0.0:
                _shift_add(moved[k], bel[k], (first_r + i, first_c + j), float(weight), scratch)
    if headings > 1:
        step = float(wrap_angle(yaws[1] - yaws[0]))
        first_h, w_h = region_kernel(
            float(wrap_angle(dyaw)) / step, math.hypot(parts.sd_rot1, parts.sd_rot2) / abs(step)
        )
        turned = np.zeros_like(moved)
        product = np.empty_like(moved)
        for i, weight in enumerate(w_h):
            # np.roll along the headings, without its copy: the two wrapped blocks added in place
            shift = (first_h + i) % headings
            np.multiply(moved, weight, out=product)
            turned[shift:] += product[: headings - shift]
            turned[:shift] += product[headings - shift :]
        moved = turned
    if free is not None:
        moved *= free[None, :, :]
    total = moved.sum()
    if normalize and total > 0:
        moved /= total
    return moved


def grid_yaws(headings: int) -> np.ndarray:
    """The yaws in the grid frame of beliefloc's headings: heading 0 points up the grid (+y), then
    clockwise, as :meth:`~beliefloc.model.GridLayout.heading_yaw` (whose map-frame yaws are these
    plus the frame's yaw). Shape ``(headings,)``, in (-pi, pi]."""
    h = np.arange(headings, dtype=np.float64)
    yaws: np.ndarray = wrap_angle(math.pi / 2 - 2 * math.pi * h / headings)
    return yaws
