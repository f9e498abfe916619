"""Where a sweep's work runs: a local process pool, or Ray tasks on a local or remote
cluster. Both take a top-level function and its arguments (picklable), run each call in a
worker process that has run :func:`flylog.sweep.warm.start_worker` once, and yield
``(index, result)`` as calls finish, in any order; ``running`` is how many calls are being
worked on at the moment. A call whose worker process died (killed, out of memory, a crash
in compiled code) gives ``lost(index, message)`` when the caller passes ``lost``; without
it, a WorkerLost error.

Inputs and outputs travel by path: on a cluster, every node must see the sweep's inputs
and its output directory at the same paths (shared storage, e.g. NFS).
"""

from __future__ import annotations

import contextlib
import enum
import gc
import os
from collections.abc import Callable, Iterator, Sequence
from typing import Any, Protocol, TypeVar

from flylog.errors import ConfigError, FlylogError
from flylog.sweep.warm import start_worker

A = TypeVar("A")
R = TypeVar("R")

RAY_ADDRESS_ENV = "RAY_ADDRESS"


class Backend(enum.Enum):
    PROCESSES = "processes"
    RAY = "ray"


def default_workers() -> int:
    """The cores this process may use."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        return os.cpu_count() or 1


class WorkerLost(FlylogError):
    """A worker process ended before its call returned."""


Lost = Callable[[int, str], R]


def _lost(lost: Lost[R] | None, index: int, message: str) -> R:
    if lost is None:
        raise WorkerLost(message)
    return lost(index, message)


class Executor(Protocol):
    workers: int

    @property
    def running(self) -> int: ...

    def map_unordered(
        self, fn: Callable[[A], R], items: Sequence[A], lost: Lost[R] | None = None
    ) -> Iterator[tuple[int, R]]: ...

    def close(self) -> None: ...

    def abort(self) -> None: ...


def _warmed_call(fn: Callable[[A], R], item: A, numba_threads: int) -> R:
    start_worker(numba_threads)
    return fn(item)


def _plain_call(fn: Callable[[A], R], item: A, numba_threads: int) -> R:
    return fn(item)


def _pool_call(fn: Callable[[A], R], item: A, numba_threads: int) -> R:
    from flylog.process import stoppable_call

    return stoppable_call(fn, item)


def _start_pool_worker(numba_threads: int, parent: int, warm: bool) -> None:
    """A pool worker's start: it ends with its parent (a sweep killed with SIGKILL leaves
    no worker behind), a stop signal ends it cleanly, its warnings are one line each, and
    (``warm``) :func:`~flylog.sweep.warm.start_worker`."""
    from flylog.process import end_with_parent, one_line_warnings, stop_on_signals, stoppable_call

    stop_on_signals()
    end_with_parent(parent)
    one_line_warnings()
    if warm:
        stoppable_call(start_worker, numba_threads)


def _resource_tracker_ignoring_hangup() -> None:
    """Start multiprocessing's resource tracker (the helper process that frees the pool's
    semaphores) with SIGHUP ignored, as it ignores SIGINT and SIGTERM itself: a closed
    terminal signals the whole process group, and a tracker ended by SIGHUP makes the
    pool's processes print its tracebacks on their way out. An ignored signal stays
    ignored across exec; the tracker ends when the last process using it ends."""
    import signal
    import threading
    from multiprocessing import resource_tracker

    if not hasattr(signal, "SIGHUP") or threading.current_thread() is not threading.main_thread():
        resource_tracker.ensure_running()
        return
    previous = signal.signal(signal.SIGHUP, signal.SIG_IGN)
    try:
        resource_tracker.ensure_running()
    finally:
        signal.signal(signal.SIGHUP, previous)


class ProcessPool:
    """``workers`` processes (spawned: fresh interpreters, as Ray's workers are), each with
    ``numba_threads`` numba threads (1 by default: the workers already fill the cores);
    ``warm``: each runs :func:`~flylog.sweep.warm.start_worker` first."""

    def __init__(self, workers: int, *, numba_threads: int = 1, warm: bool = True) -> None:
        self.workers = workers
        self._threads = numba_threads
        self._warm = warm
        self._pending = 0
        self._pool = self._new_pool()

    def _new_pool(self) -> Any:
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor

        context = multiprocessing.get_context("spawn")
        _resource_tracker_ignoring_hangup()
        return ProcessPoolExecutor(
            max_workers=self.workers,
            mp_context=context,
            initializer=_start_pool_worker,
            initargs=(self._threads, os.getpid(), self._warm),
        )

    def _submit(self, fn: Callable[[A], R], item: A) -> Any:
        from concurrent.futures.process import BrokenProcessPool

        try:
            return self._pool.submit(_pool_call, fn, item, self._threads)
        except BrokenProcessPool:  # a worker died in an earlier map: start afresh
            self._pool.shutdown(wait=True)
            self._pool = self._new_pool()
            return self._pool.submit(_pool_call, fn, item, self._threads)

    @property
    def running(self) -> int:
        return min(self.workers, self._pending)

    def map_unordered(
        self, fn: Callable[[A], R], items: Sequence[A], lost: Lost[R] | None = None
    ) -> Iterator[tuple[int, R]]:
        from concurrent.futures import as_completed
        from concurrent.futures.process import BrokenProcessPool

        futures = {self._submit(fn, item): i for i, item in enumerate(items)}
        self._pending = len(futures)
        try:
            for future in as_completed(futures):
                self._pending -= 1
                i = futures[future]
                try:
                    result = future.result()
                except BrokenProcessPool as exc:  # every call not finished then fails so
                    result = _lost(lost, i, f"a worker process ended abruptly ({exc})")
                yield i, result
        finally:
            for future in futures:
                future.cancel()
            self._pending = 0

    def close(self) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)

    def abort(self) -> None:
        """Cancel the queued calls and stop the running ones: each worker gets SIGTERM,
        removes its partial outputs and ends (:func:`flylog.process.stop_on_signals`)."""
        import signal

        processes = dict(getattr(self._pool, "_processes", None) or {})
        self._pool.shutdown(wait=False, cancel_futures=True)
        for process in processes.values():
            if process.is_alive():
                with contextlib.suppress(ProcessLookupError):
                    os.kill(process.pid, signal.SIGTERM)
        for process in processes.values():
            process.join()
        self._pool.shutdown(wait=True)
        # Its queues' semaphores are released when collected: now, not at the exit, where
        # multiprocessing's resource tracker reports them as leaked (the exception that
        # stopped the sweep keeps its frames, and this pool, alive until then).
        self._pool = None
        gc.collect()


class RayCluster:
    """Ray tasks of one CPU each. ``address`` (or ``RAY_ADDRESS``) joins a running cluster;
    without either, a local cluster of ``workers`` CPUs is started and stopped with this."""

    def __init__(self, workers: int, *, address: str | None = None) -> None:
        try:
            import ray
        except ImportError:
            msg = "--backend ray needs Ray: pip install 'flylog[ray]'"
            raise ConfigError(msg) from None
        self._ray = ray
        address = address or os.environ.get(RAY_ADDRESS_ENV) or None
        kwargs: dict[str, Any] = {"include_dashboard": False, "log_to_driver": False}
        if address is None:
            # a new local cluster, never one found on the machine
            kwargs.update(address="local", num_cpus=workers)
        else:
            kwargs.update(address=address)
        try:
            ray.init(**kwargs)
        except (ConnectionError, ValueError, RuntimeError) as exc:
            msg = f"cannot start or join the Ray cluster {address or '(local)'}: {exc}"
            raise ConfigError(msg) from None
        self.workers = int(ray.cluster_resources().get("CPU", workers))
        self._pending = 0
        self._remote: Any = ray.remote(num_cpus=1, max_retries=0)(_warmed_call)

    @property
    def running(self) -> int:
        return min(self.workers, self._pending)

    def map_unordered(
        self, fn: Callable[[A], R], items: Sequence[A], lost: Lost[R] | None = None
    ) -> Iterator[tuple[int, R]]:
        ray = self._ray
        from ray.exceptions import RayError

        refs = {self._remote.remote(fn, item, 1): i for i, item in enumerate(items)}
        pending = list(refs)
        self._pending = len(pending)
        try:
            while pending:
                done, pending = ray.wait(pending, num_returns=1)
                self._pending = len(pending)
                for ref in done:
                    try:
                        result = ray.get(ref)
                    except RayError as exc:  # its worker or node died, or it was cancelled
                        first = str(exc).strip().splitlines()[:1]
                        message = f"Ray lost the task: {type(exc).__name__}: {''.join(first)}"
                        result = _lost(lost, refs[ref], message)
                    yield refs[ref], result
        finally:
            for ref in pending:
                ray.cancel(ref)
            self._pending = 0

    def close(self) -> None:
        self._ray.shutdown()

    def abort(self) -> None:
        self._ray.shutdown()


def check_backend(backend: Backend, address: str | None) -> None:
    """ConfigError for a backend that cannot run here, before a sweep writes anything: Ray
    not installed, a cluster address without the Ray backend."""
    import importlib.util

    if backend is not Backend.RAY and address is not None:
        msg = "a cluster address needs the Ray backend (--backend ray)"
        raise ConfigError(msg, parameter="address")
    if backend is Backend.RAY and importlib.util.find_spec("ray") is None:
        msg = "--backend ray needs Ray: pip install 'flylog[ray]'"
        raise ConfigError(msg, parameter="backend")


def make_executor(backend: Backend, workers: int, *, address: str | None = None) -> Executor:
    if workers < 1:
        msg = f"workers must be at least 1, got {workers}"
        raise ConfigError(msg)
    if backend is Backend.RAY:
        return RayCluster(workers, address=address)
    if address is not None:
        msg = "a cluster address needs the Ray backend"
        raise ConfigError(msg, parameter="address")
    return ProcessPool(workers)
