"""Sweeps: many independent, seeded units of work (episodes, trials) run on one of three backends.

A *sweep* (:class:`Sweep`) is a picklable description of the work -- the model, or the domain, and
the settings -- with :meth:`Sweep.runner`, which builds what a worker reuses between units (a
successor evaluator, a search space) and returns a *runner*: unit index -> its JSON-ready result.
A unit draws its random numbers from generators keyed by (seed, index) only, so a result does not
depend on which worker ran it, nor on what that worker ran before: every backend gives the same
results, and :func:`in_order` puts them back in index order.

Backends (:class:`Backend`), each yielding ``(index, result)`` pairs as units finish:

* :class:`SerialBackend` -- this process, one unit after the other (today's behaviour);
* :class:`PoolBackend` -- a process pool of the standard library (forked while this process has no
  other thread, else spawned). The sweep goes to each worker once, in the pool's initializer;
* :class:`DaskBackend` -- an existing ``dask.distributed`` cluster (the optional extra
  ``beliefloc[dask]``). The sweep is scattered to every worker once (``broadcast=True``).

Units are sent in chunks (:func:`chunks`): large ones first, smaller towards the end, so that the
dispatch costs little and the workers finish together. Every chunk carries the client's beliefloc
version; a worker running another refuses it (:class:`VersionMismatchError`). A worker reports its
peak memory with each chunk (:attr:`Backend.peak_rss`).
"""

from __future__ import annotations

import contextlib
import math
import os
import sys
import threading
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

from beliefloc import __version__
from beliefloc.errors import BeliefLocError

Result = dict[str, Any]
"""A unit's JSON-ready result (one line of a results file)."""
Runner = Callable[[int], Result]

CONNECT_TIMEOUT = 8.0
"""Seconds to wait for a Dask scheduler before saying it cannot be reached (the whole command: under 10 s)."""
CHUNKS_PER_WORKER = 4
"""The first chunks hold about ``1 / (CHUNKS_PER_WORKER x workers)`` of what is left, the later ones less."""
MAX_CHUNK = 64
"""No chunk holds more units than this (results come back, and are written, at least this often)."""
DASK_INSTALL = "pip install 'beliefloc[dask]'"


class SweepError(BeliefLocError):
    """A backend cannot run the sweep: no Dask, an unreachable scheduler, a worker that failed."""


class VersionMismatchError(SweepError):
    """A worker runs another beliefloc version than the client: its results might differ."""


class Sweep(Protocol):
    """What a backend runs: picklable, and sent to each worker once."""

    def runner(self) -> Runner:
        """The per-worker state (built once per worker and thread) and the function that runs one unit."""
        ...


class Backend(Protocol):
    """Where units run."""

    workers: int
    """How many units can run at once."""
    peak_rss: dict[str, int]
    """Peak resident memory (bytes) of each worker that ran a chunk of the last :meth:`run`, by
    worker; empty for serial. A forked worker's counts the pages it shares with the client."""

    def run(self, sweep: Sweep, indices: Sequence[int]) -> Iterator[tuple[int, Result]]:
        """``(index, result)`` for every index, as units finish (not in order)."""
        ...

    def close(self) -> None: ...


def chunks(indices: Sequence[int], workers: int) -> list[list[int]]:
    """``indices`` cut into consecutive chunks of decreasing size (guided self-scheduling): each
    holds ``1 / (CHUNKS_PER_WORKER x workers)`` of the units left, at least 1, at most
    :data:`MAX_CHUNK`; one unit per chunk for a single worker is never needed, so a serial run is
    one chunk per :data:`MAX_CHUNK` units."""
    out: list[list[int]] = []
    start = 0
    while start < len(indices):
        left = len(indices) - start
        size = max(1, min(MAX_CHUNK, math.ceil(left / (CHUNKS_PER_WORKER * max(1, workers)))))
        out.append(list(indices[start : start + size]))
        start += size
    return out


def in_order(pairs: Iterable[tuple[int, Result]], indices: Sequence[int]) -> Iterator[tuple[int, Result]]:
    """The results of ``pairs`` (which may come in any order) in the order of ``indices``, each as
    soon as every earlier one has come: the later ones wait in a buffer."""
    waiting: dict[int, Result] = {}
    position = 0
    for index, result in pairs:
        waiting[index] = result
        while position < len(indices) and indices[position] in waiting:
            yield indices[position], waiting.pop(indices[position])
            position += 1
    if position < len(indices):
        raise SweepError(f"the backend returned no result for unit {indices[position]}")


# --- the worker's side -------------------------------------------------------------------------------


@dataclass(frozen=True)
class ChunkResult:
    results: list[tuple[int, Result]]
    worker: str
    peak_rss: int
    """Bytes."""


_local = threading.local()


def _runner_for(sweep: Sweep) -> Runner:
    """The runner of ``sweep`` in this worker thread, started once (a Dask worker passes every task
    the same scattered object; a pool worker keeps the one its initializer got)."""
    cached = getattr(_local, "runner", None)
    if cached is not None and cached[0] is sweep:
        return cached[1]  # type: ignore[no-any-return]
    runner = sweep.runner()
    _local.runner = (sweep, runner)  # holds the sweep, so its id is never reused while cached
    return runner


def run_chunk(sweep: Sweep, version: str, indices: Sequence[int]) -> ChunkResult:
    """Run ``indices`` of ``sweep`` here, after checking that this worker runs the client's version."""
    if version != __version__:
        raise VersionMismatchError(
            f"a worker runs beliefloc {__version__} but the client runs {version}: its results could differ; "
            f"install beliefloc {version} on every worker (or the worker's version here)"
        )
    runner = _runner_for(sweep)
    results = [(index, runner(index)) for index in indices]
    return ChunkResult(results, _worker_name(), peak_rss())


def peak_rss() -> int:
    """This process's peak resident memory in bytes (0 where the system does not say)."""
    try:
        import resource
    except ImportError:  # pragma: no cover - Windows
        return 0
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return int(peak if sys.platform == "darwin" else peak * 1024)


def _worker_name() -> str:
    import socket

    return f"{socket.gethostname()}:{os.getpid()}"


_POOL_SWEEP: list[Sweep] = []
"""The sweep a pool worker's initializer received (one per worker process)."""


def _pool_initializer(sweep: Sweep, parent: int = 0) -> None:
    """A pool worker's start: it keeps the sweep, and dies with its parent. On Linux the kernel
    kills it when the parent ends, by whatever signal (``PR_SET_PDEATHSIG``); a worker whose parent
    is already gone (it was re-parented) exits at once."""
    import signal

    signal.signal(signal.SIGTERM, signal.SIG_DFL)  # not the parent's handler, forked with it
    if sys.platform == "linux":
        import ctypes

        with contextlib.suppress(OSError, AttributeError):
            ctypes.CDLL(None, use_errno=True).prctl(1, int(signal.SIGKILL))  # 1: PR_SET_PDEATHSIG
    if parent and os.getppid() != parent:
        os._exit(1)
    _POOL_SWEEP[:] = [sweep]


def _pool_chunk(version: str, indices: list[int]) -> ChunkResult:
    return run_chunk(_POOL_SWEEP[0], version, indices)


# --- backends ----------------------------------------------------------------------------------------


@dataclass
class SerialBackend:
    """In this process, in index order. ``start`` replaces :meth:`Sweep.runner` (a runner with
    per-step callbacks, say)."""

    start: Callable[[], Runner] | None = None
    workers: int = 1
    peak_rss: dict[str, int] = field(default_factory=dict)

    def run(self, sweep: Sweep, indices: Sequence[int]) -> Iterator[tuple[int, Result]]:
        runner = (self.start or sweep.runner)()
        for index in indices:
            yield index, runner(index)

    def close(self) -> None:
        return None


@dataclass
class PoolBackend:
    """A pool of ``workers`` processes of the standard library (``concurrent.futures``).

    Its processes are forked when that is safe -- on Linux, while this process runs no other thread
    (no clingo, rich or dask thread is copied half-way through its work): a forked worker inherits
    the sweep instead of importing beliefloc and unpickling it, which saves about half a second per
    run. Otherwise they are spawned (``context``: force one)."""

    workers: int
    peak_rss: dict[str, int] = field(default_factory=dict)
    context: str | None = None
    _pool: Any = None
    _handlers: dict[int, Any] = field(default_factory=dict)

    def start_method(self) -> str:
        """``context``, else "fork" when it is safe now, else "spawn"."""
        import threading

        if self.context is not None:
            return self.context
        return "fork" if sys.platform == "linux" and threading.active_count() == 1 else "spawn"

    def run(self, sweep: Sweep, indices: Sequence[int]) -> Iterator[tuple[int, Result]]:
        """Starts the pool and sends every chunk now (forked processes start before any thread of
        the pool's, or of a progress bar); the results come from the iterator returned."""
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor

        pool = ProcessPoolExecutor(
            max_workers=self.workers,
            mp_context=multiprocessing.get_context(self.start_method()),
            initializer=_pool_initializer,
            initargs=(sweep, os.getpid()),
        )
        self._pool = pool
        self.peak_rss = {}
        pending = {pool.submit(_pool_chunk, __version__, chunk) for chunk in chunks(indices, self.workers)}
        self._stop_on_signals(pool)
        return self._results(pool, pending)

    def _stop_on_signals(self, pool: Any) -> None:
        """SIGTERM and SIGHUP (when nothing else handles them) end the workers, then this process,
        as Ctrl-C does: a pool never outlives the command that started it."""
        import signal

        if threading.current_thread() is not threading.main_thread():
            return

        def stop(signum: int, _frame: object) -> None:
            for process in list(getattr(pool, "_processes", {}).values()):
                with contextlib.suppress(OSError, ValueError):
                    process.kill()
            raise SystemExit(128 + signum)

        for signum in (signal.SIGTERM, signal.SIGHUP):
            if signal.getsignal(signum) == signal.SIG_DFL:
                self._handlers[signum] = signal.signal(signum, stop)

    def _restore_signals(self) -> None:
        import signal

        for signum, handler in self._handlers.items():
            signal.signal(signum, handler)
        self._handlers.clear()

    def _results(self, pool: Any, pending: set[Any]) -> Iterator[tuple[int, Result]]:
        from concurrent.futures import FIRST_COMPLETED, wait

        try:
            while pending:
                done, pending = wait(pending, return_when=FIRST_COMPLETED)
                for future in done:
                    chunk = _chunk_result(future.result)
                    self.peak_rss[chunk.worker] = max(self.peak_rss.get(chunk.worker, 0), chunk.peak_rss)
                    yield from chunk.results
        finally:
            pool.shutdown(wait=True, cancel_futures=True)
            self._restore_signals()

    def close(self) -> None:
        """Stops the pool of the last :meth:`run` (its chunks not started are dropped)."""
        self._restore_signals()
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None


def _chunk_result(result: Callable[[], ChunkResult]) -> ChunkResult:
    """A finished chunk's result; a worker that died (killed, out of memory) is a :class:`SweepError`."""
    from concurrent.futures.process import BrokenProcessPool

    try:
        return result()
    except BrokenProcessPool as exc:
        raise SweepError(f"a worker process died ({exc}); the results so far are kept") from None


class DaskBackend:
    """The workers of a running ``dask.distributed`` scheduler at ``address`` (``tcp://HOST:PORT``).
    Connecting happens here, before any work: an error within :data:`CONNECT_TIMEOUT` seconds when
    the scheduler cannot be reached."""

    def __init__(self, address: str, *, timeout: float = CONNECT_TIMEOUT) -> None:
        self.distributed = _distributed()
        self.address = address
        self.peak_rss: dict[str, int] = {}
        _reachable(address, timeout)
        started: list[Any] = []

        class _Client(self.distributed.Client):  # type: ignore[misc,name-defined]
            """A client whose failed start is not closed again when collected (that waits 20 s)."""

            def __del__(self) -> None:
                if self in started:
                    super().__del__()

        try:
            self.client: Any = _Client(address, timeout=timeout, set_as_default=False)
        except (OSError, TimeoutError) as exc:
            raise SweepError(
                f"cannot reach the Dask scheduler at {address} within {timeout:g} s ({_reason(exc)}); "
                "is it running, and is the address tcp://HOST:PORT?"
            ) from None
        except Exception as exc:  # something answers there, but not as a scheduler does
            raise SweepError(
                f"{address} answers, but not as a Dask scheduler does ({type(exc).__name__}: {_reason(exc)})"
            ) from None
        started.append(self.client)
        self.workers = max(1, sum(self.client.nthreads().values()))

    def run(self, sweep: Sweep, indices: Sequence[int]) -> Iterator[tuple[int, Result]]:
        """Scatters the sweep to every worker and submits every chunk now; the results come from the
        iterator returned."""
        if not self.client.nthreads():
            raise SweepError(f"the Dask scheduler at {self.address} has no workers")
        self.peak_rss = {}
        shared = self.client.scatter(sweep, broadcast=True, hash=False)
        futures = [
            self.client.submit(run_chunk, shared, __version__, chunk, pure=False)
            for chunk in chunks(indices, self.workers)
        ]
        return self._results(shared, futures)

    def _results(self, shared: Any, futures: list[Any]) -> Iterator[tuple[int, Result]]:
        try:
            for future in self.distributed.as_completed(futures, loop=self.client.loop):
                chunk: ChunkResult = future.result()
                self.peak_rss[chunk.worker] = max(self.peak_rss.get(chunk.worker, 0), chunk.peak_rss)
                yield from chunk.results
        finally:
            for future in futures:
                future.cancel()
            shared.release()

    def close(self) -> None:
        self.client.close()


def _distributed() -> Any:
    """``dask.distributed``, imported when a scheduler is asked for (typed as Any: it has no stubs)."""
    import importlib

    try:
        return importlib.import_module("distributed")
    except ImportError:
        raise SweepError(f"a Dask scheduler needs the optional extra 'dask': {DASK_INSTALL}") from None


def _reachable(address: str, timeout: float) -> None:
    """A TCP connection to the scheduler's host and port can be opened (a fast answer for a wrong
    address or a stopped scheduler)."""
    import socket
    from urllib.parse import urlsplit

    try:
        parts = urlsplit(address if "://" in address else f"tcp://{address}")
        host, port = parts.hostname, parts.port
    except ValueError:  # 'tcp://[::1:8786': an unclosed IPv6 bracket, a port out of range
        host, port = None, None
    if not host or port is None:
        raise SweepError(
            f"{address}: not a scheduler address; write tcp://HOST:PORT (an IPv6 host in brackets: tcp://[::1]:8786)"
        )
    try:
        with socket.create_connection((host, port), timeout=timeout) as connection:
            _handshake(connection, address, timeout)
    except TimeoutError:
        raise SweepError(
            f"the Dask scheduler at {address} accepted the connection but said nothing within {timeout:g} s: "
            "is a Dask scheduler listening there?"
        ) from None
    except OSError as exc:
        raise SweepError(
            f"cannot reach the Dask scheduler at {address} ({_reason(exc)}); is it running, and is the address "
            "tcp://HOST:PORT?"
        ) from None


MAX_HANDSHAKE_FRAME = 64 * 1024 * 1024
"""The largest first message a scheduler may announce (a real handshake is a few hundred bytes)."""


def _handshake(connection: Any, address: str, timeout: float) -> None:
    """A Dask scheduler speaks first: its handshake message, framed as a count of frames and each
    frame's length (little-endian 64-bit). Within ``timeout`` (:class:`TimeoutError` otherwise),
    and announcing no frame larger than :data:`MAX_HANDSHAKE_FRAME`."""
    import struct
    import time

    deadline = time.monotonic() + timeout
    received = b""
    while len(received) < 24:  # the total length, the frame count, the first frame's length
        connection.settimeout(max(0.001, deadline - time.monotonic()))
        chunk = connection.recv(24 - len(received))
        if not chunk:
            raise SweepError(f"{address} closed the connection without a Dask handshake")
        received += chunk
    total, count, first = struct.unpack("<QQQ", received)
    if not 1 <= count <= 1_000 or max(total, first) > MAX_HANDSHAKE_FRAME:
        raise SweepError(
            f"{address} announced a first message of {max(total, first):,} bytes in {count:,} frames; a Dask "
            "scheduler's handshake is a few hundred bytes: is a Dask scheduler listening there?"
        )


def _reason(exc: BaseException) -> str:
    text = str(exc).strip().splitlines()
    return text[0] if text else type(exc).__name__


WORKERS_PER_CORE = 4
"""A pool has at most this many processes per core (``--workers`` above it is capped with a note)."""


def pool_size(workers: int, units: int | None = None) -> tuple[int, str | None]:
    """The processes for ``--workers`` (0: one per core) and ``units`` of work: never more than the
    units, nor than :data:`WORKERS_PER_CORE` × the cores; with a note when ``workers`` was capped."""
    available = cores()
    wanted = available if workers == 0 else workers
    size = min(wanted, WORKERS_PER_CORE * available)
    note = None
    if size < wanted:
        note = (
            f"--workers {workers:,}: capped at {size} processes "
            f"({WORKERS_PER_CORE} per core of the {available} this process may use)"
        )
    if units is not None:
        size = min(size, max(1, units))
    return max(1, size), note


def backend(
    workers: int = 1,
    scheduler: str | None = None,
    *,
    start: Callable[[], Runner] | None = None,
    units: int | None = None,
    on_note: Callable[[str], None] | None = None,
) -> Backend:
    """The backend for ``workers`` processes (0: one per core; 1: this process; see
    :func:`pool_size` for the cap, ``units``: the units to run, and ``on_note``: told of a cap) or a
    Dask scheduler's address; ``start``: the serial backend's runner (:class:`SerialBackend`)."""
    if scheduler is not None:
        return DaskBackend(scheduler)
    workers, note = pool_size(workers, units)
    if note is not None and on_note is not None:
        on_note(note)
    if workers == 1:
        return SerialBackend(start)
    return PoolBackend(workers)


def cores() -> int:
    """The cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - macOS, Windows
        return os.cpu_count() or 1
