"""Where a sweep's work runs: a local process pool, or Ray tasks on a local or remote
cluster. Both take a top-level function and its arguments (picklable), run each call in a
worker process that has run :func:`flylog.sweep.warm.warm_up` once, and yield
``(index, result)`` as calls finish, in any order; ``running`` is how many calls are being
worked on at the moment.

Inputs and outputs travel by path: on a cluster, every node must see the sweep's inputs
and its output directory at the same paths (shared storage, e.g. NFS).
"""

from __future__ import annotations

import enum
import os
from collections.abc import Callable, Iterator, Sequence
from typing import Any, Protocol, TypeVar

from flylog.errors import ConfigError
from flylog.sweep.warm import warm_up

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


class Executor(Protocol):
    workers: int

    @property
    def running(self) -> int: ...

    def map_unordered(
        self, fn: Callable[[A], R], items: Sequence[A]
    ) -> Iterator[tuple[int, R]]: ...

    def close(self) -> None: ...


def _warmed_call(fn: Callable[[A], R], item: A, numba_threads: int) -> R:
    warm_up(numba_threads)
    return fn(item)


class ProcessPool:
    """``workers`` processes (spawned: fresh interpreters, as Ray's workers are), each with
    ``numba_threads`` numba threads (1 by default: the workers already fill the cores)."""

    def __init__(self, workers: int, *, numba_threads: int = 1) -> None:
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor

        self.workers = workers
        self._threads = numba_threads
        self._pending = 0
        self._pool = ProcessPoolExecutor(
            max_workers=workers,
            mp_context=multiprocessing.get_context("spawn"),
            initializer=warm_up,
            initargs=(numba_threads,),
        )

    @property
    def running(self) -> int:
        return min(self.workers, self._pending)

    def map_unordered(self, fn: Callable[[A], R], items: Sequence[A]) -> Iterator[tuple[int, R]]:
        from concurrent.futures import as_completed

        futures = {
            self._pool.submit(_warmed_call, fn, item, self._threads): i
            for i, item in enumerate(items)
        }
        self._pending = len(futures)
        try:
            for future in as_completed(futures):
                self._pending -= 1
                yield futures[future], future.result()
        finally:
            for future in futures:
                future.cancel()
            self._pending = 0

    def close(self) -> None:
        self._pool.shutdown(wait=True, cancel_futures=True)


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

    def map_unordered(self, fn: Callable[[A], R], items: Sequence[A]) -> Iterator[tuple[int, R]]:
        ray = self._ray
        refs = {self._remote.remote(fn, item, 1): i for i, item in enumerate(items)}
        pending = list(refs)
        self._pending = len(pending)
        try:
            while pending:
                done, pending = ray.wait(pending, num_returns=1)
                self._pending = len(pending)
                for ref in done:
                    yield refs[ref], ray.get(ref)
        finally:
            for ref in pending:
                ray.cancel(ref)
            self._pending = 0

    def close(self) -> None:
        self._ray.shutdown()


def make_executor(backend: Backend, workers: int, *, address: str | None = None) -> Executor:
    if workers < 1:
        msg = f"workers must be at least 1, got {workers}"
        raise ConfigError(msg)
    if backend is Backend.RAY:
        return RayCluster(workers, address=address)
    if address is not None:
        msg = "--address goes with --backend ray"
        raise ConfigError(msg)
    return ProcessPool(workers)
