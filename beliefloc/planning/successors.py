"""Colledanchise's ``NextNodes`` (Algorithm 1, lines 39-52), vectorised.

For a belief ``b`` and every action ``a`` and observation ``o`` with ``p(o | a, b) > 0``, the
successor ``b'`` has::

    predicted = T_aᵀ b                     (b itself for a perception action)
    p_o       = Σ_j predicted_j O_a[j, o]
    b'_j      = predicted_j O_a[j, o] / p_o

The search needs only ``p_o``, ``H(b')`` and ``max(b')`` to rank a successor, and states with the
same noise-free readings (the same *signature*) share their row of ``O_a``. So with per-signature
sums ``A_g = Σ_{j∈g} predicted_j``, ``B_g = Σ_{j∈g} predicted_j ln predicted_j`` and maxima
``M_g``, and ``C[g, o]`` the likelihood of o in group g::

    p_o      = Σ_g A_g C[g, o]
    H(b'_o)  = ln p_o - (1 / p_o) Σ_g C[g, o] (B_g + A_g ln C[g, o])
    max b'_o = max_g M_g C[g, o] / p_o

which costs O(|S|) per action plus O(groups × observations) -- never |Ω| posterior vectors.
Best-first search materialises beliefs only for the nodes it expands (:meth:`successor`); the
contingent planner, which merges equal beliefs, takes them all with their statistics
(:meth:`successors`).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from types import ModuleType

import numpy as np

from beliefloc.belief import entropy, predict
from beliefloc.model import Action, Model
from beliefloc.source import threads
from beliefloc.source.sparse_kernels import csc_matvec as _csc_matvec
from beliefloc.source.sparse_kernels import csr_matvec as _csr_matvec

fused: ModuleType | None
"""The compiled passes for large beliefs (``_fused.c``; setup.py builds them where a C compiler is found),
or None: then the NumPy passes below, the same plans. Setting it to None (tests, a comparison) makes the
evaluators made afterwards and :func:`~beliefloc.planning.best_first.key_and_peak` use NumPy's."""
try:
    from beliefloc.planning import _fused as fused
except ImportError:  # pragma: no cover - an install without the extension
    fused = None


def fused_weighted_sum(
    compiled: ModuleType, belief: np.ndarray, column: np.ndarray, label: np.ndarray, out: np.ndarray
) -> float:
    """``compiled.weighted_sum`` (``_fused.c``: ``out = belief * column[label]`` and its pairwise sum),
    the two halves of NumPy's pairwise tree side by side on :func:`beliefloc.source.threads.pool`: the
    tree's top splits at ``n // 2`` rounded down to a multiple of 8 and adds its halves' sums, so the
    halves summed apart and added are the very bits of the whole (at 10^7 states 9 ms a Bayes update on
    one core)."""
    n = belief.size
    if n <= SPLIT_FROM:
        total: float = compiled.weighted_sum(belief, column, label, out)
        return total
    half = n // 2
    half -= half % 8  # numpy's pairwise_sum
    low, high = threads.side_by_side(
        lambda: compiled.weighted_sum(belief[:half], column, label[:half], out[:half]),
        lambda: compiled.weighted_sum(belief[half:], column, label[half:], out[half:]),
    )
    return float(low) + float(high)


SPLIT_FROM = 2**20
"""Entries from which :func:`fused_weighted_sum` and the search's keys take their two halves on two cores
(fewer do not pay for the hand-off)."""
_LARGE_BYTES = 2**20
"""Beliefs of at least this many bytes are predicted into reused vectors (:meth:`SuccessorEvaluator._predict`)."""
_SPARE_BELIEFS = 4
"""Vectors of |S| floats :class:`SuccessorEvaluator` keeps for reuse (handed back by the search)."""


@dataclass(frozen=True)
class SuccessorStats:
    """What the search needs to know about one successor before it is expanded."""

    action: int
    """Index into ``model.actions``."""
    observation: int | None
    """Joint observation index, or None for an action that observes nothing."""
    probability: float
    """``p(o | a, b)`` (1 for an action that observes nothing)."""
    entropy: float
    """``H(b')`` in nats."""
    max_belief: float
    """``max_j b'_j``."""
    change: float | None = None
    """For a perception's reading, ``Σ_j |b'_j - b_j|``: how far it moves the belief it read (None for an
    action that moves)."""


@dataclass(eq=False)
class _Groups:
    """States of one observation model sorted by signature, with the group boundaries."""

    starts: np.ndarray
    label: np.ndarray | None
    """Each state's group (its position in ``starts``), or None when :meth:`likelihood` must be
    computed part by part (a part's table not float64)."""
    likelihood: np.ndarray
    """``C[g, o]``: likelihood of every observation in each group (groups × observations)."""
    log_likelihood: np.ndarray
    """``C ln C`` is written ``C * log_likelihood`` with 0 where C = 0."""
    sort: Callable[[], np.ndarray]
    """The states in signature order, stably (:attr:`order` computes it once, when asked)."""
    _order: np.ndarray | None = None

    @property
    def order(self) -> np.ndarray:
        """The states in signature order: only NumPy's passes read it (the compiled ones read :attr:`label`),
        so a large model's evaluator does not keep it (80 MB at 10^7 states) unless one of them runs."""
        if self._order is None:
            self._order = self.sort()
        return self._order


def reading_keys(action: Action, n_states: int) -> np.ndarray:
    """Each state's *signature*: one integer for the tuple of its parts' confusion rows (states with
    the same key read every part alike)."""
    key = np.zeros(n_states, dtype=np.int64)
    for part in action.observation.parts:
        key = key * part.confusion.shape[0] + part.truth
    return key


def _groups(action: Action, n_states: int, compact: bool = False) -> _Groups | None:
    """The signature groups of ``action``'s observations. ``compact``, for the compiled passes: fewer than 2^16
    signatures labelled in the narrowest unsigned type (a byte a state where NumPy's gathers want ``intp``),
    and the signature order not kept (:attr:`_Groups.order` sorts again if a NumPy pass asks for it)."""
    parts = action.observation.parts
    if not parts:
        return None
    key = reading_keys(action, n_states)
    exact = all(part.confusion.dtype == np.float64 for part in parts)
    label: np.ndarray | None = None
    if n_states and key.min() >= 0 and key.max() < 2**16:
        # few signatures (the usual case): the same stable order, radix-sorted on 16 bits; the groups
        # counted, and each state's group looked up from its key, without gathering 10^7 keys
        small = key.astype(np.uint16)
        order = np.argsort(small, kind="stable")
        counts = np.bincount(small)
        present = np.flatnonzero(counts)
        starts = np.r_[0, np.cumsum(counts[present])[:-1]].astype(np.intp)
        if exact:
            # intp for NumPy: a gather by narrower labels converts them first (1.4 ms, not 0.5, at 10^6)
            kind = np.min_scalar_type(len(present) - 1) if compact else np.dtype(np.intp)
            lookup = np.zeros(len(counts), dtype=kind)
            lookup[present] = np.arange(len(present), dtype=kind)
            label = lookup[small]
    else:
        order = np.argsort(key, kind="stable")
        sorted_key = key[order]
        boundary = np.r_[True, sorted_key[1:] != sorted_key[:-1]]
        starts = np.flatnonzero(boundary)
        if exact:
            label = np.empty(n_states, dtype=np.intp)
            label[order] = np.cumsum(boundary, dtype=np.intp) - 1

    def sort() -> np.ndarray:
        # the same stable order as above, from the same keys (a rare pass: no 16-bit radix sort)
        return np.argsort(reading_keys(action, n_states), kind="stable")

    # with a label, O[:, o] = C[label, o]: one gather from a small table instead of one per part; the
    # table's entries are the same products in the same order as ObservationModel.likelihood's
    table = action.observation.likelihood_matrix(order[starts])
    with np.errstate(divide="ignore"):
        log_table = np.where(table > 0.0, np.log(np.where(table > 0.0, table, 1.0)), 0.0)
    return _Groups(starts, label, table, log_table, sort, None if compact else order)


def _entropy(belief: np.ndarray, work: np.ndarray | None = None) -> float:
    """:func:`beliefloc.belief.entropy`, bit for bit, without copying a belief whose every entry is > 0
    (every belief of a noisy model: selecting them is most of the cost on 10^6 states); ``work``, an
    array of the belief's shape, holds ``b ln b`` instead of two new arrays."""
    if belief.size:
        # no pass to ask whether every entry is > 0 first: a 0 (log -inf, times 0: NaN) or a negative
        # entry (NaN) makes the sum NaN, and only then are the entries selected
        with np.errstate(divide="ignore", invalid="ignore"):
            terms = np.log(belief, out=work)
            np.multiply(belief, terms, out=terms)
            total = float(terms.sum())
        if not math.isnan(total):
            return -total  # -(Σ x) is Σ(-x) exactly: negation commutes with rounding
    return entropy(belief)


_sum = np.add.reduce
_max = np.maximum.reduce
"""What ``x.sum()`` and ``x.max()`` call for a 1-d float vector, without their Python wrappers (a blocked sweep
makes ~1,200 of these calls per 10^7-state vector: 0.1-0.2 s of a 10^7-state search)."""

_BLOCK = 2**15
"""Entries of a belief :func:`_entropy_max` takes at a time (256 kB: a block stays in the cache
between the passes over it)."""


def _entropy_max(belief: np.ndarray, work: np.ndarray) -> tuple[float, float]:
    """``(_entropy(belief, work), float(belief.max()))`` bit for bit, in one sweep over the belief:
    block by block, each block's ``b ln b`` written, multiplied, summed and its maximum taken while it
    is in the cache (four passes over 8-80 MB read from memory once; a prediction's entropy and
    maximum took 1.9 ms at 10^6 states, 0.3-0.5 ms now).

    The same sum, not a close one: NumPy sums a vector pairwise, halving it at ``n // 2`` rounded
    down to a multiple of 8 down to blocks of 128; the blocks here are the nodes of that very tree
    (NumPy sums each one exactly as it would inside the whole), and their sums are added back up
    the tree. A maximum is the same in any order. A zero or negative entry (a NaN sum) takes
    :func:`_entropy`'s other path. ``work`` has the belief's shape."""

    def sweep(start: int, count: int) -> tuple[float, float]:
        if count <= _BLOCK:
            block = belief[start : start + count]
            terms = np.log(block, out=work[:count])
            np.multiply(block, terms, out=terms)
            return float(_sum(terms)), float(_max(block))
        half = count // 2
        half -= half % 8  # numpy's pairwise_sum
        low_sum, low_max = sweep(start, half)
        high_sum, high_max = sweep(start + half, count - half)
        return low_sum + high_sum, max(low_max, high_max)

    if belief.ndim != 1 or not belief.size or belief.dtype != np.float64 or not belief.flags.c_contiguous:
        return _entropy(belief, work), float(belief.max())
    with np.errstate(divide="ignore", invalid="ignore"):
        total, peak = sweep(0, belief.size)
    if math.isnan(total) or math.isnan(peak):
        return entropy(belief), float(belief.max())
    return -total, peak


def _blocked_vector(vector: np.ndarray) -> bool:
    """Whether the blocked sweeps take ``vector``: contiguous float64, not empty."""
    return vector.ndim == 1 and vector.size > 0 and vector.dtype == np.float64 and vector.flags.c_contiguous


def _weighted_sum(
    predicted: np.ndarray, column: np.ndarray, label: np.ndarray, out: np.ndarray, work: np.ndarray
) -> float:
    """``out = predicted * column[label]`` (the unnormalised Bayes update, ``column`` the likelihood of
    one observation per signature group) and ``out.sum()``, bit for bit, in one blocked sweep: each
    block's likelihoods gathered, multiplied and summed while they are in the cache (the tree of
    :func:`_entropy_max`), instead of a likelihood vector written and three passes over 8-80 MB."""
    column = np.ascontiguousarray(column)

    def sweep(start: int, count: int) -> float:
        if count <= _BLOCK:
            likelihood = np.take(column, label[start : start + count], out=work[:count], mode="clip")
            block = np.multiply(predicted[start : start + count], likelihood, out=out[start : start + count])
            return float(_sum(block))
        half = count // 2
        half -= half % 8  # numpy's pairwise_sum
        return sweep(start, half) + sweep(start + half, count - half)

    return sweep(0, predicted.size)


_BLOCKED_GROUPS = 256
"""Signature groups up to which :func:`_group_sums` sweeps them block by block (a few Python calls a
group: with many small groups the whole-vector passes cost less)."""


def _group_sums(
    predicted: np.ndarray, groups: _Groups, rank: np.ndarray, first: np.ndarray, second: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """:meth:`SuccessorEvaluator._group_sums` bit for bit: the states put in signature order, then
    one sweep over them, each block's ``b ln b``, sums and maximum taken while it is in the cache
    (six more passes over 8-80 MB and a vector written, before). None when an entry is 0 or negative
    (a NaN sum: the whole-vector code handles it).

    The states are *scattered* to their places (``ordered[rank] = b``, ``rank`` the inverse of
    ``groups.order``), not gathered (``b[order]``): the same vector, but a gather in signature order
    reads the whole belief once per group (each group's states are spread over all of it), a scatter
    reads it once and writes one run per group (10^7 states, 16 groups: 14 ms against 80 ms).

    ``np.add.reduceat`` sums a group ``g`` of entries ``x[s:e]`` as ``x[s] + pairwise(x[s+1:e])``,
    NumPy's pairwise sum of the rest (see :func:`_entropy_max`); the rest is swept here by the blocks
    of that very tree, and the group's first entry added last. ``first`` and ``second`` are scratch
    vectors of the belief's length."""
    order, starts = groups.order, groups.starts
    ordered = first
    ordered[rank] = predicted
    count_groups = len(starts)
    mass = np.empty(count_groups)
    mass_log_mass = np.empty(count_groups)
    peak = np.empty(count_groups)

    def sweep(start: int, count: int) -> tuple[float, float, float]:
        if count <= _BLOCK:
            block = ordered[start : start + count]
            terms = np.log(block, out=second[:count])
            np.multiply(block, terms, out=terms)
            return float(_sum(block)), float(_sum(terms)), float(_max(block))
        half = count // 2
        half -= half % 8  # numpy's pairwise_sum
        low = sweep(start, half)
        high = sweep(start + half, count - half)
        return low[0] + high[0], low[1] + high[1], max(low[2], high[2])

    ends = [*starts[1:].tolist(), len(order)]
    with np.errstate(divide="ignore", invalid="ignore"):
        for g, (start, end) in enumerate(zip(starts.tolist(), ends, strict=True)):
            # the group's first entry as a block of one: the same vectorised logarithm as the others
            head = ordered[start : start + 1]
            head_term = np.multiply(head, np.log(head, out=second[:1]), out=second[:1])
            head_mass, head_xlogx, head_max = float(head[0]), float(head_term[0]), float(head[0])
            if end - start > 1:
                rest_mass, rest_xlogx, rest_max = sweep(start + 1, end - start - 1)
                mass[g] = head_mass + rest_mass
                mass_log_mass[g] = head_xlogx + rest_xlogx
                peak[g] = max(head_max, rest_max)
            else:
                mass[g], mass_log_mass[g], peak[g] = head_mass, head_xlogx, head_max
    if np.isnan(mass_log_mass).any() or np.isnan(peak).any():
        return None
    return mass, mass_log_mass, peak


_Sums = tuple[np.ndarray, np.ndarray, np.ndarray]
"""Each signature group's ``Σ b``, ``Σ b ln b`` and ``max b``."""


def _combined(first: _Sums, second: _Sums) -> _Sums:
    """The group sums of two parts of a belief's states, as those of their union."""
    return first[0] + second[0], first[1] + second[1], np.maximum(first[2], second[2])


class SuccessorEvaluator:
    """Successor statistics and beliefs for one model; precomputes signature groups once."""

    def __init__(self, model: Model) -> None:
        self.model = model
        self._work: tuple[np.ndarray, np.ndarray] | None = None
        self._spare: list[np.ndarray] = []
        self._large = model.n_states * 8 >= _LARGE_BYTES
        self._ranks: dict[int, np.ndarray] = {}
        # large beliefs only: small ones keep NumPy's sums bit for bit (the paper's worlds' figures)
        self._fused = fused if self._large else None
        compact = self._fused is not None  # the compiled passes read labels of a byte or two
        self._groups = [_groups(action, model.n_states, compact) for action in model.actions]
        self._fused_kinds: bool | None = None

    def recycle(self, vector: np.ndarray) -> None:
        """Take back a belief this evaluator made that nobody refers to any more; a later prediction
        or successor is written into it. A fresh 8-80 MB array costs its page faults (a third of a
        10^6 search's time went to them), a reused one a pass that zeroes it at most. The caller
        promises that it keeps no reference: the array will be overwritten."""
        if len(self._spare) < _SPARE_BELIEFS and vector.shape == (self.model.n_states,) and vector.dtype == np.float64:
            self._spare.append(vector)

    def _vector(self) -> np.ndarray:
        """A vector of |S| floats to write a belief into: a recycled one, or a new one (a large one with its
        memory faulted in on two cores, :func:`threads.filled`)."""
        if self._spare:
            return self._spare.pop()
        vector = np.empty(self.model.n_states)
        return threads.filled(vector, 0.0) if self._large else vector

    def _predict(self, action: Action, belief: np.ndarray) -> np.ndarray:
        """:func:`beliefloc.belief.predict` into a recycled vector, bit for bit.

        ``T_aᵀ b`` is SciPy's ``csr_matvec`` over ``T_aᵀ`` in :func:`~beliefloc.belief.predict`: each
        entry starts at 0 and adds its row's products in the row's order, which for a transpose made by
        SciPy is the order of the source states. The arrays of ``T_a`` in CSR are those of ``T_aᵀ`` in
        CSC, and ``csc_matvec`` over them adds the same products onto each entry in the same order (source
        states ascending): the same sums, with no transpose to build (1.5-2.3 s and 1.1 GB for the four
        moves of a 10^7-state world; a product costs about 10 % more). A transpose already built (by
        :func:`~beliefloc.belief.update`, say) is used as it is."""
        transition = action.transition
        if not self._large:
            return predict(action, belief)  # fewer checks and calls: a small belief's page faults cost nothing
        if transition is None:
            out = self._vector()
            np.copyto(out, belief)
            return out
        fused = self._fused_predict(action, belief, stats=False)
        if fused is not None:
            return fused[0]
        built = action.__dict__.get("transition_transposed")  # the cached_property, if computed
        matrix, kernel = (transition, _csc_matvec) if built is None else (built, _csr_matvec)
        if (
            kernel is None
            or matrix.format != "csr"
            or matrix.dtype != np.float64
            or belief.dtype != np.float64
            or belief.shape != (self.model.n_states,)
            or not belief.flags.c_contiguous
        ):
            return predict(action, belief)
        out = self._vector()
        out.fill(0.0)
        n_rows, n_columns = matrix.shape
        if built is None:
            n_rows, n_columns = n_columns, n_rows  # the CSC form of the transpose: its shape
        kernel(n_rows, n_columns, matrix.indptr, matrix.indices, matrix.data, belief, out)
        return out

    def _fused_predict(
        self, action: Action, belief: np.ndarray, stats: bool, out: np.ndarray | None = None
    ) -> tuple[np.ndarray, float, float] | None:
        """``T_aᵀ b`` into a recycled vector, bit for bit :func:`~beliefloc.belief.predict`'s, by a
        compiled pass; with ``stats``, its entropy and maximum taken in the same call, chunk by chunk while
        it is in the cache (equal to :func:`_entropy_max`'s to a few ulps: another
        summation order and logarithm). At 10^7 states a move's prediction, entropy and maximum took
        ~0.12 s in three NumPy passes and a zeroing, 0.04-0.05 s here. None where the pass does not
        apply (no extension, a matrix of another kind). Safe to run beside another call given ``out``
        (a vector of |S| floats: :meth:`_vector` is not)."""
        if self._fused is None or not _blocked_vector(belief) or belief.shape != (self.model.n_states,):
            return None
        # T_aᵀ's rows if the transpose is built (localize's updates build it), else T_a's own rows: one
        # more pass over the prediction, but no transpose to build (0.5-0.9 s and 280 MB a move at 10^7)
        built = action.__dict__.get("transition_transposed")  # the cached_property, if computed
        matrix = action.transition if built is None else built
        if (
            matrix is None
            or matrix.format != "csr"
            or matrix.dtype != np.float64
            or matrix.indices.dtype != matrix.indptr.dtype
            or matrix.indptr.dtype not in (np.int32, np.int64)
        ):
            return None
        if out is None:
            out = self._vector()
        xlogx, peak, nan = self._fused.predict_stats(
            matrix.indptr, matrix.indices, matrix.data, belief, out, stats, built is None
        )
        if nan and stats:  # a NaN entry: the NumPy statistics (entropy() skips it, max() returns it)
            return out, entropy(out), float(out.max())
        return out, -xlogx, peak

    def _fused_group_sums(
        self, groups: _Groups, predicted: np.ndarray, start: int = 0, stop: int | None = None
    ) -> _Sums | None:
        """:meth:`_group_sums` by the compiled pass: each group's ``Σ b``, ``Σ b ln b`` and ``max b`` in one
        read of the belief and its labels (equal to NumPy's to a few ulps), over the states
        ``start:stop`` (all by default; a group with none there has sums 0 and maximum -inf). None where
        it does not apply, or when an entry is NaN (the NumPy code then says so)."""
        if self._fused is None or groups.label is None or not _blocked_vector(predicted):
            return None
        count = len(groups.starts)
        mass, mass_log_mass, peak = np.empty(count), np.empty(count), np.empty(count)
        if self._fused.group_stats(predicted[start:stop], groups.label[start:stop], mass, mass_log_mass, peak):
            return None
        return mass, mass_log_mass, peak

    def _buffers(self) -> tuple[np.ndarray, np.ndarray]:
        """Two scratch vectors of |S| floats, reused by every evaluation: a new 80 MB array costs its
        page faults at 10^7 states."""
        if self._work is None:
            self._work = (np.empty(self.model.n_states), np.empty(self.model.n_states))
        return self._work

    def entropy_max(self, belief: np.ndarray) -> tuple[float, float]:
        """``(entropy(belief), float(belief.max()))`` bit for bit; for a large belief in one blocked sweep
        (:func:`_entropy_max`) instead of a copy of its support and three passes (the start belief's
        estimate: 0.2 s at 10^7 states)."""
        if self._large and _blocked_vector(belief) and belief.shape == (self.model.n_states,):
            if self._fused is not None:
                xlogx, peak, nan = self._fused.belief_stats(belief)
                if not nan:
                    return -xlogx, peak
            return _entropy_max(belief, self._buffers()[0])
        return entropy(belief), float(belief.max())

    def evaluate(self, belief: np.ndarray, beliefs: dict[int, np.ndarray] | None = None) -> list[SuccessorStats]:
        """Every successor of ``belief`` with non-zero probability, in action then observation order.

        With ``beliefs``, the successor beliefs that came out whole are put there by action index:
        those of the actions that observe nothing, whose successor is the prediction itself (the
        very array :meth:`successor` would compute again, at 50 ms a prediction at 10^7 states)."""
        if self._fused_applies(belief):
            return self._evaluate_fused(belief, beliefs)
        out: list[SuccessorStats] = []
        work = self._buffers()[0]
        for index, action in enumerate(self.model.actions):
            # a perception's prediction is the belief itself, only read here: no copy
            predicted = belief if action.transition is None else self._predict(action, belief)
            groups = self._groups[index]
            if groups is None:
                if self._large:
                    h, peak = self.entropy_max(predicted)
                else:
                    h, peak = _entropy(predicted, work), float(predicted.max())
                out.append(SuccessorStats(index, None, 1.0, h, peak))
                self._keep_whole(index, predicted, belief, beliefs)
                continue
            out.extend(self._observe(index, groups, predicted))
            if predicted is not belief:
                self.recycle(predicted)
        return out

    def _keep_whole(
        self, index: int, predicted: np.ndarray, belief: np.ndarray, beliefs: dict[int, np.ndarray] | None
    ) -> None:
        """An action that observes nothing: its successor is ``predicted`` whole, kept in ``beliefs`` (a
        copy when it is the belief itself) or handed back for reuse."""
        if beliefs is not None:
            beliefs[index] = predicted if predicted is not belief else belief.copy()
        elif predicted is not belief:
            self.recycle(predicted)

    def _fused_applies(self, belief: np.ndarray) -> bool:
        """Whether :meth:`_evaluate_fused` takes ``belief``: the compiled passes are built, the belief is
        large, and every action's matrix and signature groups are of the kinds they read."""
        if self._fused is None or not _blocked_vector(belief) or belief.shape != (self.model.n_states,):
            return False
        if self._fused_kinds is None:
            matrices = [a.transition for a in self.model.actions if a.transition is not None]
            self._fused_kinds = all(
                m.format == "csr"
                and m.dtype == np.float64
                and m.indices.dtype == m.indptr.dtype
                and m.indptr.dtype in (np.int32, np.int64)
                for m in matrices
            ) and all(groups is None or groups.label is not None for groups in self._groups)
        return self._fused_kinds

    def _evaluate_fused(self, belief: np.ndarray, beliefs: dict[int, np.ndarray] | None) -> list[SuccessorStats]:
        """:meth:`evaluate` by the compiled passes, side by side on the cores this process may use
        (:func:`beliefloc.source.threads.pool`; each pass releases the interpreter's lock). At 10^7
        states an expansion's four moves are ~0.05 s of passes each and a look's group sums ~0.04 s: the
        look's are taken in two halves, last, so that two cores end together (five passes on two cores
        otherwise wait for the fifth)."""
        actions = self.model.actions
        n = self.model.n_states
        pool = threads.pool()
        outs = [self._vector() if action.transition is not None else None for action in actions]
        whole = [i for i, a in enumerate(actions) if a.transition is not None or self._groups[i] is None]
        looks = [i for i, a in enumerate(actions) if a.transition is None and self._groups[i] is not None]
        cuts = (0, n // 2, n)  # with or without a pool: the same sums, bit for bit, on any number of cores
        tasks = [(i, 0, n) for i in whole] + [(i, lo, hi) for i in looks for lo, hi in itertools.pairwise(cuts)]

        def measure(task: tuple[int, int, int]) -> tuple[np.ndarray, tuple[float, float] | None, _Sums | None]:
            index, lo, hi = task
            action, groups = actions[index], self._groups[index]
            predicted = belief
            if action.transition is not None:
                fused = self._fused_predict(action, belief, groups is None, outs[index])
                assert fused is not None  # _fused_applies checked the matrices
                predicted = fused[0]
                if groups is None:
                    return predicted, (fused[1], fused[2]), None
            if groups is None:
                return predicted, None, None  # a perception that observes nothing: taken below
            return predicted, None, self._fused_group_sums(groups, predicted, lo, hi)

        done = list(pool.map(measure, tasks)) if pool else [measure(task) for task in tasks]
        results: dict[int, tuple[np.ndarray, tuple[float, float] | None, _Sums | None]] = {}
        for (index, _, _), (predicted, entropy_peak, sums) in zip(tasks, done, strict=True):
            if index in results:  # the second half of a look's sums
                earlier = results[index][2]
                if earlier is None or sums is None:  # a NaN entry: the NumPy sums below
                    results[index] = (predicted, None, None)
                else:
                    results[index] = (predicted, None, _combined(earlier, sums))
            else:
                results[index] = (predicted, entropy_peak, sums)
        out: list[SuccessorStats] = []
        for index in range(len(actions)):
            predicted, entropy_peak, sums = results[index]
            groups = self._groups[index]
            if groups is None:
                h, peak = entropy_peak if entropy_peak is not None else self.entropy_max(predicted)
                out.append(SuccessorStats(index, None, 1.0, h, peak))
                self._keep_whole(index, predicted, belief, beliefs)
                continue
            if sums is None:  # a NaN entry: the NumPy sums say so
                sums = self._group_sums(groups, predicted)
            out.extend(self._observation_stats(index, groups, sums))
            if predicted is not belief:
                self.recycle(predicted)
        return out

    def successors(self, belief: np.ndarray) -> Iterator[tuple[SuccessorStats, np.ndarray]]:
        """:meth:`evaluate` with each successor belief too (one prediction per action)."""
        for index, action in enumerate(self.model.actions):
            predicted = predict(action, belief)
            groups = self._groups[index]
            if groups is None:
                yield SuccessorStats(index, None, 1.0, _entropy(predicted), float(predicted.max())), predicted
                continue
            for stats in self._observe(index, groups, predicted):
                assert stats.observation is not None
                weighted: np.ndarray = predicted * self._likelihood(index, stats.observation)
                weighted /= weighted.sum()
                yield stats, weighted

    def _observe(self, index: int, groups: _Groups, predicted: np.ndarray) -> list[SuccessorStats]:
        sums = self._fused_group_sums(groups, predicted)
        if sums is None and self._large and len(groups.starts) <= _BLOCKED_GROUPS:
            sums = _group_sums(predicted, groups, self._rank(index, groups), *self._buffers())
        if sums is None:
            sums = self._group_sums(groups, predicted)
        return self._observation_stats(index, groups, sums)

    def _observation_stats(self, index: int, groups: _Groups, sums: _Sums) -> list[SuccessorStats]:
        """Every observation's successor statistics from the signature groups' sums (the module docs)."""
        mass, mass_log_mass, peak = sums
        table = groups.likelihood
        probability = mass @ table
        inner = table.T @ mass_log_mass + (table * groups.log_likelihood).T @ mass
        top = (peak[:, None] * table).max(axis=0)
        change: list[float | None] | None = None
        if self.model.actions[index].transition is None:
            # Σ_j |b_j C[g_j, o] / p_o - b_j| by group: how far each reading moves the belief it read
            with np.errstate(divide="ignore", invalid="ignore"):
                change = (np.abs(table / probability - 1.0).T @ mass).tolist()
        out = []
        for o in np.flatnonzero(probability > 0.0).tolist():
            p = float(probability[o])
            entropy = max(0.0, float(np.log(p) - inner[o] / p))
            moved = None if change is None else change[o]
            out.append(SuccessorStats(index, o, p, entropy, min(1.0, float(top[o] / p)), moved))
        return out

    def _rank(self, index: int, groups: _Groups) -> np.ndarray:
        """Each state's place in signature order (the inverse of ``groups.order``), for action ``index``;
        made once."""
        rank = self._ranks.get(index)
        if rank is None:
            rank = np.empty(len(groups.order), dtype=np.intp)
            rank[groups.order] = np.arange(len(groups.order), dtype=np.intp)
            self._ranks[index] = rank
        return rank

    def _group_sums(self, groups: _Groups, predicted: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Each signature group's ``Σ b``, ``Σ b ln b`` and ``max b`` (see the module docs)."""
        first, second = self._buffers()
        # order is a permutation: "clip" never clips (and "raise" would copy through a buffer)
        ordered = np.take(predicted, groups.order, out=first, mode="clip")
        # ordered ln ordered: the np.where below when no entry is 0 (then no sum is NaN); no pass to
        # ask first
        with np.errstate(divide="ignore", invalid="ignore"):
            xlogx = np.log(ordered, out=second)
            np.multiply(ordered, xlogx, out=xlogx)
        mass_log_mass = np.add.reduceat(xlogx, groups.starts)
        if np.isnan(mass_log_mass).any():
            with np.errstate(divide="ignore", invalid="ignore"):
                xlogx = np.where(ordered > 0.0, ordered * np.log(ordered), 0.0)
            mass_log_mass = np.add.reduceat(xlogx, groups.starts)
        mass = np.add.reduceat(ordered, groups.starts)
        peak = np.maximum.reduceat(ordered, groups.starts)
        return mass, mass_log_mass, peak

    def successor(self, belief: np.ndarray, action: int, observation: int | None) -> np.ndarray:
        """The successor belief itself (a new array)."""
        act = self.model.actions[action]
        if observation is None:
            return self._predict(act, belief)
        # a perception's prediction is the belief itself: the product below is the new array
        predicted = belief if act.transition is None else self._predict(act, belief)
        groups = self._groups[action]
        if self._large and groups is not None and groups.label is not None and _blocked_vector(predicted):
            weighted = self._vector()
            column = np.ascontiguousarray(groups.likelihood[:, observation])
            if self._fused is not None:  # the same bits in one compiled pass (two halves on two cores)
                total = fused_weighted_sum(self._fused, predicted, column, groups.label, weighted)
            else:
                total = _weighted_sum(predicted, column, groups.label, weighted, self._buffers()[0])
        else:
            likelihood = self._likelihood(action, observation)
            weighted = np.multiply(predicted, likelihood, out=self._vector()) if self._large else predicted * likelihood
            total = weighted.sum()
        if predicted is not belief:
            self.recycle(predicted)
        weighted /= total
        return weighted

    def _likelihood(self, action: int, observation: int) -> np.ndarray:
        """``O_a[:, o]``, equal to ``ObservationModel.likelihood(o)`` bit for bit."""
        groups = self._groups[action]
        if groups is None or groups.label is None:
            return self.model.actions[action].observation.likelihood(observation)
        if not self._large:
            small: np.ndarray = groups.likelihood[:, observation][groups.label]
            return small
        # the column gathered into the first scratch vector (free between evaluations)
        column: np.ndarray = np.take(
            groups.likelihood[:, observation], groups.label, out=self._buffers()[0], mode="clip"
        )
        return column
