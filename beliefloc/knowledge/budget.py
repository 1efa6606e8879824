"""Grounding and solving under a budget of time and memory.

clingo grounds in C++ and cannot be interrupted while it does: ``n(0..100000000).`` takes
gigabytes and ignores Ctrl-C, and ``Control.interrupt`` only stops a search. So the first grounding
of a knowledge base runs in a forked child process (:func:`run_budgeted`) with its address space
bounded by :data:`~beliefloc.source.limits.GROUNDING_BYTES` (more than the parent holds already) and its
time by :data:`~beliefloc.source.limits.GROUNDING_SECONDS`; the child sends back what it found (answer sets
as text, clingo's messages) and exits. A child that runs out of time is killed, one that runs out
of memory fails in clingo (or is killed by the system), and either way the parent raises
:class:`~beliefloc.errors.LimitError` naming the budget and the environment variable that raises
it. Ctrl-C stops the child with the parent, at once.

A search that is solved in the process itself (after an observation, multi-shot) runs
asynchronously and is waited for in short slices (:func:`wait_solved`): Ctrl-C and the time budget
cancel it.

Without ``os.fork`` (Windows) the grounding runs in the process, with no budget.
"""

from __future__ import annotations

import contextlib
import json
import os
import selectors
import signal
import time
import warnings
from collections.abc import Callable
from typing import Any

from beliefloc import errors
from beliefloc.errors import BeliefLocError, LimitError
from beliefloc.source import limits

_SLICE = 0.05
"""Seconds between looks at a running search (how soon Ctrl-C is noticed)."""


def can_fork() -> bool:
    """Whether the budget can be enforced here (a POSIX system)."""
    return hasattr(os, "fork") and hasattr(os, "waitpid")


def time_exceeded(where: str) -> LimitError:
    limit = limits.GROUNDING_SECONDS
    return LimitError(
        f"{where}: grounding and solving took more than the limit of {limit.value:,} seconds; if the "
        f"knowledge base is what you meant, raise it with the environment variable {limit.variable}=N"
    )


def memory_exceeded(where: str, how: str = "") -> LimitError:
    limit = limits.GROUNDING_BYTES
    return LimitError(
        f"{where}: grounding and solving needed more than the limit of {limit.value:,} bytes of memory{how} "
        "(a rule such as n(1..100000000). makes as many ground atoms); if the knowledge base is what you meant, "
        f"raise it with the environment variable {limit.variable}=N"
    )


def run_budgeted(task: Callable[[], Any], where: str) -> Any:
    """``task()`` (which returns JSON data) in a child process under the budget; its value.

    A :class:`BeliefLocError` raised by the task is raised again here (same class, same message);
    ``where`` names the knowledge base in the messages of the budget."""
    if not can_fork():  # pragma: no cover - Windows
        return task()
    read_end, write_end = os.pipe()
    with warnings.catch_warnings():  # Python 3.12+ warns of forking with threads; the child runs no Python thread
        warnings.simplefilter("ignore", DeprecationWarning)
        pid = os.fork()
    if pid == 0:  # pragma: no cover - the child (coverage does not follow it)
        os.close(read_end)
        _child(task, write_end)
    os.close(write_end)
    try:
        data = _collect(pid, read_end, where)
    except BaseException:
        _kill(pid)
        raise
    finally:
        os.close(read_end)
    status = _reap(pid)
    return _outcome(data, status, where)


def _child(task: Callable[[], Any], fd: int) -> None:  # pragma: no cover - runs in the child
    """Run ``task`` and write its outcome to ``fd``; never returns."""
    code = 0
    try:
        with contextlib.suppress(ValueError):
            signal.signal(signal.SIGINT, signal.SIG_DFL)  # Ctrl-C: gone at once, even inside clingo
        devnull = os.open(os.devnull, os.O_RDWR)
        for target in (0, 1, 2):  # clingo's own messages (a PANIC) must not reach the terminal
            os.dup2(devnull, target)
        _limit_child()
        try:
            outcome: dict[str, Any] = {"ok": task()}
        except MemoryError:
            outcome = {"memory": True}
        except BeliefLocError as exc:
            outcome = {"error": [type(exc).__name__, str(exc)]}
        except RuntimeError as exc:
            outcome = {"memory": True} if "bad_alloc" in str(exc) else {"crash": f"{type(exc).__name__}: {exc}"}
        except Exception as exc:
            outcome = {"crash": f"{type(exc).__name__}: {exc}"}
        payload = json.dumps(outcome).encode()
        view = memoryview(payload)
        while view:
            written = os.write(fd, view)
            view = view[written:]
    except BaseException:
        code = 70
    finally:
        os._exit(code)


def _limit_child() -> None:  # pragma: no cover - runs in the child
    import resource

    memory = _address_space() + limits.GROUNDING_BYTES.value
    with contextlib.suppress(ValueError, OSError):
        resource.setrlimit(resource.RLIMIT_AS, (memory, memory))
    seconds = limits.GROUNDING_SECONDS.value + 2  # the parent kills it sooner; this is for a parent that died
    with contextlib.suppress(ValueError, OSError):
        _soft, hard = resource.getrlimit(resource.RLIMIT_CPU)
        if hard == resource.RLIM_INFINITY or seconds < hard:
            resource.setrlimit(resource.RLIMIT_CPU, (seconds, hard))


def _address_space() -> int:  # pragma: no cover - runs in the child
    """Bytes of address space the process holds now (0 when it cannot tell)."""
    try:
        with open("/proc/self/statm", "rb") as stream:
            return int(stream.read().split()[0]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):
        import resource

        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024


def _collect(pid: int, fd: int, where: str) -> bytes:
    """Everything the child writes, before the deadline; kills it and raises when it is late."""
    deadline = time.monotonic() + limits.GROUNDING_SECONDS.value
    chunks: list[bytes] = []
    with selectors.DefaultSelector() as selector:
        selector.register(fd, selectors.EVENT_READ)
        while True:
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                _kill(pid)
                raise time_exceeded(where)
            if selector.select(min(remaining, 1.0)):
                chunk = os.read(fd, 1 << 16)
                if not chunk:
                    return b"".join(chunks)
                chunks.append(chunk)


def _kill(pid: int) -> None:
    with contextlib.suppress(OSError):
        os.kill(pid, signal.SIGKILL)
    _reap(pid)


def _reap(pid: int) -> int:
    """The child's wait status (0 when it was reaped already)."""
    while True:
        try:
            return os.waitpid(pid, 0)[1]
        except ChildProcessError:
            return 0
        except InterruptedError:  # pragma: no cover - PEP 475 retries
            continue


def _outcome(data: bytes, status: int, where: str) -> Any:
    try:
        outcome = json.loads(data) if data else None
    except ValueError:
        outcome = None
    if isinstance(outcome, dict):
        if "ok" in outcome:
            return outcome["ok"]
        if "error" in outcome:
            name, message = outcome["error"]
            cls = getattr(errors, name, None)
            if isinstance(cls, type) and issubclass(cls, BeliefLocError):
                raise cls(message)
            raise errors.KnowledgeBaseError(message)
        if "memory" in outcome:
            raise memory_exceeded(where)
        raise errors.KnowledgeBaseError(f"{where}: clingo failed: {outcome.get('crash', 'no answer')}")
    if os.WIFSIGNALED(status):
        number = os.WTERMSIG(status)
        if number == signal.SIGINT:
            raise KeyboardInterrupt
        if number == getattr(signal, "SIGXCPU", None):
            raise time_exceeded(where)
        try:
            name = signal.Signals(number).name
        except ValueError:
            name = f"signal {number}"
        raise memory_exceeded(where, f" (clingo was stopped by {name})")
    code = os.WEXITSTATUS(status) if os.WIFEXITED(status) else status
    raise errors.KnowledgeBaseError(f"{where}: clingo stopped without an answer (exit code {code})")


def wait_solved(handle: Any, deadline: float, where: str) -> None:
    """Wait for an asynchronous clingo search until ``deadline`` (``time.monotonic``); cancel it and
    raise when it is late, or when the wait is interrupted (Ctrl-C)."""
    finished = False
    try:
        while not handle.wait(_SLICE):
            if time.monotonic() > deadline:
                raise time_exceeded(where)
        finished = True
    finally:
        if not finished:
            handle.cancel()
