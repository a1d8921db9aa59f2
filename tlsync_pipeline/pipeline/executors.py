"""Where tasks run: in this process, in local worker processes, or on a Dask cluster.

All three offer ``submit(fn, kwargs) -> future`` and ``wait_any(futures)``;
futures have ``result()``. Worker processes use one thread each for OpenCV
and the BLAS/OpenMP libraries, so N workers do not oversubscribe N cores.
``cores`` is how many processes a task may start itself (the checkerboard
detection of the intrinsics stage): 1 in a pool's or a cluster's worker, so
pools are never nested; the executor's share of the machine when it runs
tasks one at a time in this process.
"""

from __future__ import annotations

import concurrent.futures as cf
import multiprocessing
import os
from typing import Any, Callable

THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMEXPR_NUM_THREADS", "VECLIB_MAXIMUM_THREADS")
EXECUTORS = ("process", "serial", "dask")


def call(fn: Callable[..., Any], kwargs: dict) -> Any:
    """Run one task in a worker (single-threaded libraries)."""
    import cv2

    cv2.setNumThreads(1)
    return fn(**kwargs)


class SerialExecutor:
    """Runs each task in this process when it is submitted."""

    name = "serial"

    def __init__(self, cores: int | None = None):
        self.cores = cores or os.cpu_count() or 1

    def submit(self, fn: Callable, kwargs: dict) -> cf.Future:
        future: cf.Future = cf.Future()
        try:
            future.set_result(fn(**kwargs))
        except BaseException as exc:  # noqa: BLE001 - handed to the caller through the future
            if isinstance(exc, (KeyboardInterrupt, SystemExit)):
                raise
            future.set_exception(exc)
        return future

    def wait_any(self, futures: list) -> list:
        return [f for f in futures if f.done()]

    def close(self, cancel: bool = False) -> None:
        pass


class ProcessExecutor:
    """A pool of ``jobs`` worker processes (spawned, so they start with one thread per library)."""

    name = "process"
    cores = 1

    def __init__(self, jobs: int | None = None):
        self.jobs = jobs or os.cpu_count() or 1
        self._pool: cf.ProcessPoolExecutor | None = None
        self._saved_env: dict[str, str | None] = {}

    def submit(self, fn: Callable, kwargs: dict) -> cf.Future:
        if self._pool is None:
            # Spawned children inherit the environment: set the thread counts before they start.
            for var in THREAD_VARIABLES:
                self._saved_env[var] = os.environ.get(var)
                os.environ[var] = "1"
            self._pool = cf.ProcessPoolExecutor(self.jobs, mp_context=multiprocessing.get_context("spawn"))
        return self._pool.submit(call, fn, kwargs)

    def wait_any(self, futures: list) -> list:
        done, _ = cf.wait(futures, return_when=cf.FIRST_COMPLETED)
        return list(done)

    def close(self, cancel: bool = False) -> None:
        """Wait for the workers to finish; with cancel (an interrupted run), stop them at once."""
        if self._pool is not None:
            if cancel:
                # No public API before Python 3.14 (terminate_workers): stop the running tasks too,
                # their artefacts are written atomically and get no manifest.
                for process in list(getattr(self._pool, "_processes", {}).values()):
                    process.terminate()
            self._pool.shutdown(wait=not cancel, cancel_futures=cancel)
            self._pool = None
        for var, value in self._saved_env.items():
            if value is None:
                os.environ.pop(var, None)
            else:
                os.environ[var] = value
        self._saved_env = {}


class DaskExecutor:
    """Tasks on a Dask distributed cluster (the optional extra ``tlsync[dask]``).

    The workers must see the project's files and the work folder at the same
    paths (a shared file system).
    """

    name = "dask"
    cores = 1

    def __init__(self, scheduler: str | Any):
        try:
            from distributed import Client
        except ImportError:
            from tlsync_pipeline.errors import InputError

            raise InputError("--executor dask needs the optional extra: pip install 'tlsync[dask]'") from None
        self._own = not hasattr(scheduler, "submit")
        self.client = Client(scheduler) if self._own else scheduler

    def submit(self, fn: Callable, kwargs: dict):
        return self.client.submit(call, fn, kwargs, pure=False)

    def wait_any(self, futures: list) -> list:
        from distributed import wait

        done, _ = wait(futures, return_when="FIRST_COMPLETED")
        return list(done)

    def close(self, cancel: bool = False) -> None:
        if self._own:
            self.client.close()


def make_executor(kind: str = "process", jobs: int | None = None, scheduler: Any = None):
    """An executor by name: process (default), serial, or dask (needs ``scheduler``)."""
    from tlsync_pipeline.errors import InputError

    if kind == "serial" or (kind == "process" and jobs == 1):
        return SerialExecutor(jobs)
    if kind == "process":
        return ProcessExecutor(jobs)
    if kind == "dask":
        if scheduler is None:
            raise InputError("--executor dask needs --scheduler ADDRESS (for example tcp://host:8786)")
        return DaskExecutor(scheduler)
    raise InputError(f"unknown executor {kind!r}; expected one of: {', '.join(EXECUTORS)}")
