"""Where tasks run: in this process, in local worker processes, or on a Dask cluster.

All three offer ``submit(fn, kwargs) -> future`` and ``wait_any(futures)``;
futures have ``result()``. Worker processes use one thread each for OpenCV
and the BLAS/OpenMP libraries, so N workers do not oversubscribe N cores; the
engine's process runs its own tasks with one BLAS thread too (sync/kernels/blas.py).
``cores`` is how many processes a task may start itself (the checkerboard
detection of the intrinsics stage): 1 in a pool's or a cluster's worker, so
pools are never nested; the executor's share of the machine when it runs
tasks one at a time in this process.

Local workers fork from a server process that imported the modules the
caller names once (``forkserver`` with a preload, where the platform has it;
else each is spawned and imports them itself), so a run pays for its
imports once rather than once per worker. On Linux that server is forked
from the run's own process once the run's input checks are done, before its
lock, any task or thread (``ProcessExecutor.fork_server``): it inherits every
module the run imported (the stage modules, SciPy, and PyAV and OpenCV the
input checks loaded: about 1 s of CPU a new interpreter would import again)
and imports only the rest of the preload (the libraries that only workers
use), and only once a first task starts the pool, with the garbage collector
off, then frozen out of its workers' collections (``_import_frozen``).

Local workers never outlive the run that started them: they ignore Ctrl-C
(the terminal sends it to the whole process group; the run stops them
itself), the kernel kills them when their parent (the fork server, or the
run's process where they are spawned) dies (Linux ``PR_SET_PDEATHSIG``), and
a watchdog thread in each worker exits as soon as the run's process ends (its
multiprocessing sentinel, every platform), so a ``kill -9`` of ``tlsync run``
leaves no worker writing into the work folder without the lock.
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import ctypes
import dataclasses
import gc
import multiprocessing
import multiprocessing.connection
import multiprocessing.forkserver
import os
import select
import signal
import socket
import sys
import threading
import time
import traceback
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from types import TracebackType
from typing import Any, NoReturn

THREAD_VARIABLES = (
    "OMP_NUM_THREADS",
    "OPENBLAS_NUM_THREADS",
    "MKL_NUM_THREADS",
    "NUMEXPR_NUM_THREADS",
    "VECLIB_MAXIMUM_THREADS",
)
EXECUTORS = ("process", "serial", "dask")
STOP_POLL_S = 0.2  # how often a run waiting for its workers looks whether a stop was asked (seconds)
STOP_GRACE_S = 3.0  # how long a stopped worker may take to exit before it is killed (seconds)
_PR_SET_PDEATHSIG = 1


def die_with_parent() -> None:
    """Initializer of a worker process: ignore Ctrl-C, exit when the run's process ends, hold no semaphore of its own.

    A spawned worker was started with Ctrl-C blocked (``ProcessExecutor.submit``): one sent while it started
    waits, and is dropped here, after it is ignored; a forked one ignores it from its start (worker_context)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if hasattr(signal, "pthread_sigmask"):
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
    if sys.platform.startswith("linux"):
        try:
            ctypes.CDLL(None, use_errno=True).prctl(_PR_SET_PDEATHSIG, int(signal.SIGKILL))
        except (OSError, AttributeError):
            pass  # the watchdog below still applies
    run = multiprocessing.parent_process()
    if run is None or not run.is_alive():  # the run ended before the request above took effect
        os._exit(1)
    threading.Thread(target=_watch_run, args=(run.sentinel,), name="tlsync-parent-watchdog", daemon=True).start()
    from tqdm import tqdm

    # tqdm's default lock holds a multiprocessing semaphore; a worker stopped mid-task would leave it to the
    # resource tracker, which warns about it when the run exits. A worker draws no bar other processes share.
    tqdm.set_lock(threading.RLock())


def _watch_run(sentinel: int) -> None:
    """Exit once the run's process has ended: its end of the sentinel pipe closes with it (also after ``kill -9``)."""
    multiprocessing.connection.wait([sentinel])
    os._exit(1)


def quiet_resource_tracker() -> None:
    """Start multiprocessing's resource tracker (if not running) with its stderr discarded.

    It unlinks the semaphores of worker pools whose run was killed (kill -9), and then warns on the terminal
    about "leaked semaphore objects": its cleanup is its job, the warning only noise for users. Call before
    the first pool; fd 2 points to /dev/null while the tracker starts (milliseconds).
    """
    from multiprocessing import resource_tracker

    if sys.platform == "win32" or getattr(resource_tracker._resource_tracker, "_fd", None) is not None:  # noqa: SLF001 - no public test
        return
    saved, devnull = os.dup(2), os.open(os.devnull, os.O_WRONLY)
    try:
        sys.stderr.flush()
        os.dup2(devnull, 2)
        resource_tracker.ensure_running()
    finally:
        os.dup2(saved, 2)
        os.close(saved)
        os.close(devnull)


@contextlib.contextmanager
def _ctrl_c_held():
    """Ctrl-C blocked in this thread for the block's duration, delivered when it ends (not lost).

    A process started meanwhile inherits the block: a Ctrl-C that reaches it while the interpreter starts
    (before it can ignore the signal) would end it with a "Fatal Python error" on the terminal.
    """
    if not hasattr(signal, "pthread_sigmask") or threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)


@contextlib.contextmanager
def _ctrl_c_ignored():
    """Ctrl-C ignored for the block's duration (in the main thread), as a process started meanwhile inherits it."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


@dataclass(frozen=True)
class Called:
    """What one call on an executor gave: the function's value, the users' warnings it raised (one line each,
    in order, without repeats), its wall and CPU seconds where it ran, and whether that was another process than
    the caller's (run_each)."""

    value: Any
    warnings: tuple[str, ...] = ()
    seconds: float = 0.0
    cpu_s: float = 0.0
    elsewhere: bool = False


def call_recording_warnings(fn: Callable[..., Any], kwargs: dict) -> Called:
    """Run one function, timed; the warnings meant for users it raises come back with its value.

    Users' warnings (UserWarning and its kinds, such as a truncated video) come
    back as one-line messages for the caller to print; other warnings are shown
    as Python shows them.
    """
    start, cpu = time.perf_counter(), time.process_time()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", UserWarning)
        value = fn(**kwargs)
    messages = []
    for item in caught:
        if issubclass(item.category, UserWarning):
            messages.append(" ".join(str(item.message).split()))
        else:
            warnings.showwarning(item.message, item.category, item.filename, item.lineno)
    return Called(value, tuple(dict.fromkeys(messages)), time.perf_counter() - start, time.process_time() - cpu)


def call(fn: Callable[..., Any], kwargs: dict) -> Called:
    """Run one task in a worker (single-threaded libraries)."""
    import cv2

    cv2.setNumThreads(1)
    return call_recording_warnings(fn, kwargs)


class SerialExecutor:
    """Runs each task in this process when it is submitted."""

    name = "serial"

    def __init__(self, cores: int | None = None):
        self.cores = cores or os.cpu_count() or 1

    def submit(self, fn: Callable, kwargs: dict) -> cf.Future:
        future: cf.Future = cf.Future()
        try:
            future.set_result(call_recording_warnings(fn, kwargs))
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
    """A pool of ``jobs`` worker processes, each with one thread per library.

    preload: modules the workers import before their first task. Where the
    platform has ``forkserver``, a server process imports them once and the
    workers fork from it (each would take 0.5-1 s of CPU to import them
    itself); else the workers are spawned. Either way they start from a
    process with no thread of the run's. With a preload, on Linux, that
    server is forked from this process by ``fork_server`` (or by the first
    task), idle until a first task starts the pool.
    """

    name = "process"
    cores = 1

    def __init__(self, jobs: int | None = None, preload: tuple[str, ...] = ()):
        self.jobs = jobs or os.cpu_count() or 1
        self.preload = preload
        self._pool: cf.ProcessPoolExecutor | None = None
        self._forked = False
        self._saved_env: dict[str, str | None] = {}
        self._start_server: int | None = None

    def fork_server(self) -> None:
        """Fork the workers' server from this process now (``fork_server_here``), idle until a first task starts the
        pool; nothing when it is forked already, the pool runs, there is no preload or this process may not fork it
        (``can_fork_server``). The later it is forked, the more of this process's modules it inherits: the engine
        calls it once the run's input checks have loaded theirs, before the run takes its lock or starts a thread."""
        if self._pool is None and self._start_server is None and self.preload and can_fork_server():
            self._start_server = fork_server_here(self.preload)

    def submit(self, fn: Callable, kwargs: dict) -> cf.Future:
        if self._pool is None:
            self.fork_server()
            # The workers (and the fork server) inherit the environment: set the thread counts before they start.
            for var in THREAD_VARIABLES:
                self._saved_env[var] = os.environ.get(var)
                os.environ[var] = "1"
            quiet_resource_tracker()
            start, self._start_server = self._start_server, None  # worker_context closes it, even when interrupted
            context = worker_context(self.preload, start)
            self._forked = context.get_start_method() == "forkserver"
            self._pool = cf.ProcessPoolExecutor(self.jobs, mp_context=context, initializer=die_with_parent)
        if self._forked:  # the workers ignore Ctrl-C from their start (worker_context)
            return self._pool.submit(call, fn, kwargs)
        with _ctrl_c_held():  # the workers it may start inherit Ctrl-C blocked (until die_with_parent ignores it)
            return self._pool.submit(call, fn, kwargs)

    @property
    def started(self) -> bool:
        """Whether the worker processes have been started (by a first task)."""
        return self._pool is not None

    def wait_any(self, futures: list) -> list:
        """The futures done, once one is; KeyboardInterrupt within STOP_POLL_S of a stop asked where Python could
        not raise it (a signal handler run inside a weakref callback or a finalizer: ``stop.stop_requested``)."""
        from tlsync_pipeline.pipeline.stop import stop_requested

        while True:
            done, _ = cf.wait(futures, timeout=STOP_POLL_S, return_when=cf.FIRST_COMPLETED)
            if done:
                return list(done)
            if stop_requested():
                raise KeyboardInterrupt

    def close(self, cancel: bool = False) -> None:
        """Wait for the workers to finish; with cancel (an interrupted run), stop them at once."""
        if self._start_server is not None:  # the server forked for a pool no task started: it ends unused
            os.close(self._start_server)
            self._start_server = None
            stop_fork_server()
        if self._pool is not None:
            if cancel:
                # No public API before Python 3.14 (terminate_workers): stop the running tasks too,
                # their artefacts are written atomically and get no manifest.
                processes = list((getattr(self._pool, "_processes", None) or {}).values())
                for process in processes:
                    process.terminate()
                deadline = time.monotonic() + STOP_GRACE_S
                for process in processes:
                    process.join(max(0.0, deadline - time.monotonic()))
                    if process.is_alive():
                        process.kill()
                        process.join()
            self._pool.shutdown(wait=not cancel, cancel_futures=cancel)
            self._pool = None
            stop_fork_server(kill=cancel)
        for var, value in self._saved_env.items():
            if value is None:
                os.environ.pop(var, None)
            else:
                os.environ[var] = value
        self._saved_env = {}


def worker_context(preload: tuple[str, ...], start_server: int | None = None) -> multiprocessing.context.BaseContext:
    """How local workers start: forked from a server that imported ``preload`` once (``forkserver``), else spawned.

    start_server: the pipe that starts the server ``fork_server_here`` forked (it imports the preload now), else
    the fork server is started here (unless one runs), with the environment of this moment and Ctrl-C ignored:
    the workers it forks inherit that from their first instruction. Then this process waits until the server has
    imported ``preload`` (it forks one process that does nothing), with Ctrl-C working: one that stops the run
    meanwhile leaves no worker asked for, to start once the run is gone."""
    if "forkserver" not in multiprocessing.get_all_start_methods():
        return multiprocessing.get_context("spawn")
    context = multiprocessing.get_context("forkserver")
    context.set_forkserver_preload(list(preload))
    if start_server is not None:
        try:
            os.write(start_server, b"1")
        finally:
            os.close(start_server)
    with _ctrl_c_held(), _ctrl_c_ignored():  # a Ctrl-C meanwhile waits: Linux keeps a blocked signal pending
        multiprocessing.forkserver.ensure_running()
    ready = context.Process(target=os.getpid, name="tlsync-fork-server-ready", daemon=True)
    try:
        ready.start()
        ready.join()
    except BaseException:
        stop_fork_server(kill=True)
        raise
    return context


def can_fork_server() -> bool:
    """Whether this process may fork the run's fork server itself (``fork_server_here``): on Linux, with no thread
    but this one (a lock another thread holds would stay held in the fork), and multiprocessing's fork server
    protocol as this module speaks it (Python's own up to 3.13: no authentication key)."""
    import inspect

    return (
        sys.platform.startswith("linux")
        and threading.active_count() == 1
        and "forkserver" in multiprocessing.get_all_start_methods()
        and "authkey_r" not in inspect.signature(multiprocessing.forkserver.main).parameters
    )


def fork_server_here(preload: tuple[str, ...]) -> int | None:
    """Fork this process into multiprocessing's fork server, idle until started; the write end of the pipe that starts
    it (``worker_context``), None when a fork server runs already.

    Once started it limits its BLAS libraries to one thread each (as the workers' environment does for the
    libraries they load), imports ``preload`` and serves multiprocessing's fork requests as the server Python
    spawns does (``multiprocessing.forkserver.main``), its modules those of this process at this moment. It exits
    unused when the pipe closes unwritten (``ProcessExecutor.close``), and like Python's when this process's end
    of its "alive" pipe closes (``stop_fork_server``, or this process's end). Ctrl-C is ignored there from its
    first instruction and every other handler of this process is reset, so its workers start as a spawned
    server's do."""
    from multiprocessing import connection, util

    server = multiprocessing.forkserver._forkserver  # noqa: SLF001 - no public API to start a server other than a new interpreter
    with server._lock:  # type: ignore[attr-defined]  # noqa: SLF001
        if server._forkserver_pid is not None:  # type: ignore[attr-defined]  # noqa: SLF001
            return None
        quiet_resource_tracker()  # the workers are handed its pipe: started by this process, as by Python's server
        address = connection.arbitrary_address("AF_UNIX")  # type: ignore[attr-defined]
        with socket.socket(socket.AF_UNIX) as listener:
            listener.bind(address)
            if not util.is_abstract_socket_namespace(address):
                os.chmod(address, 0o600)
            listener.listen()
            alive_r, alive_w = os.pipe()
            start_r, start_w = os.pipe()
            sys.stdout.flush()  # not written again by the server's processes
            sys.stderr.flush()
            with _ctrl_c_held(), _opencv_without_threads():
                pid = os.fork()
                if pid == 0:
                    os.close(alive_w)
                    os.close(start_w)
                    _serve_forks(listener.fileno(), alive_r, start_r, preload)
            os.close(alive_r)
            os.close(start_r)
        server._forkserver_address = address  # type: ignore[attr-defined]  # noqa: SLF001
        server._forkserver_alive_fd = alive_w  # type: ignore[attr-defined]  # noqa: SLF001
        server._forkserver_pid = pid  # type: ignore[attr-defined]  # noqa: SLF001
    return start_w


@contextlib.contextmanager
def _opencv_without_threads():
    """OpenCV's thread pool stopped for the block (one thread, its workers joined), then as it was: a process forked
    meanwhile does not inherit a pool whose threads it lacks (its first ``cv2.setNumThreads`` would wait for them
    forever). Nothing to do where OpenCV is not loaded."""
    cv2 = sys.modules.get("cv2")
    if cv2 is None:
        yield
        return
    threads = cv2.getNumThreads()
    cv2.setNumThreads(1)
    try:
        yield
    finally:
        cv2.setNumThreads(threads)


def _serve_forks(listener: int, alive_r: int, start_r: int, preload: tuple[str, ...]) -> NoReturn:
    """The forked server's life (``fork_server_here``); it never returns to the caller's code."""
    code = 0
    try:
        for number in signal.valid_signals():
            with contextlib.suppress(OSError, ValueError):
                if callable(signal.getsignal(number)):
                    signal.signal(number, signal.SIG_DFL)
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
        ready, _, _ = select.select([start_r, alive_r], [], [])
        if start_r not in ready or os.read(start_r, 1) != b"1":
            os._exit(0)  # no pool was started
        os.close(start_r)
        for var in THREAD_VARIABLES:
            os.environ[var] = "1"
        from threadpoolctl import threadpool_limits

        threadpool_limits(limits=1, user_api="blas")  # the BLAS pools this process inherited started with more
        _import_frozen(preload)
        sys.excepthook = quiet_when_the_run_is_gone  # what a forked child shows of an error before its first task
        multiprocessing.forkserver.main(listener, alive_r, list(preload))  # the preload imported: served at once
    except SystemExit:
        pass  # multiprocessing's way out: the run closed its end of the alive pipe
    except BaseException:  # noqa: BLE001 - shown, then this process ends: the run's next fork request fails
        traceback.print_exc()
        code = 1
    finally:
        os._exit(code)


def quiet_when_the_run_is_gone(kind: type[BaseException], value: BaseException, tb: TracebackType | None) -> None:
    """The fork server's workers' hook for an error raised before their first task: silent for the EOFError of a
    run stopped while it handed a starting worker its start data (a Ctrl-C then; the worker just exits), shown as
    Python shows it otherwise."""
    if not issubclass(kind, EOFError):
        sys.__excepthook__(kind, value, tb)


def _import_frozen(preload: tuple[str, ...]) -> None:
    """Import ``preload`` (an ImportError left for a worker to meet, as multiprocessing's server does) with the garbage
    collector off, then freeze every object this process holds (``gc.freeze``): they live as long as it does, and
    the workers forked from it neither scan them at each full collection (about 0.13 s each in a run's worker, with
    some 200,000 of them) nor copy the memory pages they would touch doing so."""
    gc.disable()
    try:
        for name in preload:
            try:
                __import__(name)
            except ImportError:
                pass
    finally:
        gc.freeze()
        gc.enable()


def stop_fork_server(kill: bool = False) -> None:
    """Stop the fork server (if one runs) and wait for it: its CPU time, and its workers', then counts as this
    process's children's (``RUSAGE_CHILDREN``), as spawned workers' does; a later pool starts a new one.

    kill: at once, for a stopped run (the server may still be importing, with the terminal's output open; the
    workers it forked die with it, ``PR_SET_PDEATHSIG``)."""
    server = multiprocessing.forkserver._forkserver  # noqa: SLF001 - multiprocessing has no public API to stop it
    pid = getattr(server, "_forkserver_pid", None)
    if pid is None:
        return
    if kill:
        with contextlib.suppress(ProcessLookupError):
            os.kill(pid, signal.SIGKILL)
    server._stop()  # type: ignore[attr-defined]  # noqa: SLF001


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
        self.client: Any = Client(scheduler) if self._own else scheduler
        self._futures: list = []

    def submit(self, fn: Callable, kwargs: dict):
        future = self.client.submit(call, fn, kwargs, pure=False)
        self._futures.append(future)
        return future

    def wait_any(self, futures: list) -> list:
        from distributed import wait

        done, _ = wait(futures, return_when="FIRST_COMPLETED")
        return list(done)

    def close(self, cancel: bool = False) -> None:
        """With cancel (an interrupted run), cancel this run's tasks on the cluster."""
        if cancel:
            self.client.cancel([f for f in self._futures if not f.done()])
        self._futures = []
        if self._own:
            self.client.close()


def run_each(executor, parts: list[tuple[Callable[..., Any], dict]]) -> list[Called]:
    """``fn(**kwargs)`` for each ``(fn, kwargs)`` of ``parts`` on ``executor`` (in parallel on its workers), in order.

    For a task of the engine's own process with independent parts (render's
    cameras and charts): it hands them to the run's executor, so no pool is
    started inside another. A local pool that no task has started yet is not
    started for them: its fork server would first import OpenCV, numba and
    matplotlib (about 0.7 s of CPU), more than a camera's pictures cost, so the
    parts run in this process (``tlsync render`` alone, a run where only
    render is stale). Each Called says whether it ran in another process (its
    CPU is then not in this one's, for the task to add to its own); the first
    failed call's error is raised.
    """
    if isinstance(executor, ProcessExecutor) and not executor.started:
        executor = SerialExecutor()
    futures = [executor.submit(_part, {"fn": fn, "kwargs": kwargs, "caller": os.getpid()}) for fn, kwargs in parts]
    return [future.result().value for future in futures]


def _part(fn: Callable[..., Any], kwargs: dict, caller: int) -> Called:
    called = call_recording_warnings(fn, kwargs)
    return dataclasses.replace(called, elsewhere=os.getpid() != caller)


def make_executor(kind: str = "process", jobs: int | None = None, scheduler: Any = None, preload: tuple[str, ...] = ()):
    """An executor by name: process (default; its workers import ``preload`` first), serial, or dask (needs
    ``scheduler``)."""
    from tlsync_pipeline.errors import InputError

    if kind == "serial" or (kind == "process" and jobs == 1):
        return SerialExecutor(jobs)
    if kind == "process":
        return ProcessExecutor(jobs, preload)
    if kind == "dask":
        if scheduler is None:
            raise InputError("--executor dask needs --scheduler ADDRESS (for example tcp://host:8786)")
        return DaskExecutor(scheduler)
    raise InputError(f"unknown executor {kind!r}; expected one of: {', '.join(EXECUTORS)}")
