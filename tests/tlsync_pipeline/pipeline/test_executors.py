"""Local worker processes never outlive the process that started them.

A parent script submits tasks that record their pid and then sleep; the
parent is then killed (kill -9, which it cannot handle) or interrupted.
"""

import os
import signal
import subprocess
import sys
import time
import warnings
from pathlib import Path

import pytest

from tlsync_pipeline.pipeline import executors
from tlsync_pipeline.pipeline.executors import SerialExecutor, call_recording_warnings

TASK = """
import os, time

def sleep_and_record(path, seconds):
    with open(path + ".part", "w") as handle:
        handle.write(str(os.getpid()))
    os.replace(path + ".part", path)
    time.sleep(seconds)
    return {}
"""

PARENT = """
import sys
sys.path.insert(0, {folder!r})
import sleeper
from tlsync_pipeline.pipeline.executors import ProcessExecutor

if __name__ == "__main__":
    executor = ProcessExecutor(2, preload={preload!r})
    futures = [executor.submit(sleeper.sleep_and_record, {{"path": {folder!r} + f"/worker{{i}}", "seconds": 120}}) for i in range(2)]
    try:
        executor.wait_any(futures)
    except KeyboardInterrupt:
        executor.close(cancel=True)
        sys.exit(130)
"""


def alive(pid: int) -> bool:
    """Whether a process runs (a zombie waiting for its parent to reap it does not)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except (FileNotFoundError, ProcessLookupError):  # reaped since the signal's check, or a system without /proc
        return not Path("/proc/self").exists()
    except IndexError:
        return True


def _start_parent(tmp_path: Path, preload: tuple[str, ...] = ()) -> tuple[subprocess.Popen, list[int]]:
    (tmp_path / "sleeper.py").write_text(TASK)
    (tmp_path / "parent.py").write_text(PARENT.format(folder=str(tmp_path), preload=preload))
    parent = subprocess.Popen([sys.executable, str(tmp_path / "parent.py")], start_new_session=True)
    files = [tmp_path / "worker0", tmp_path / "worker1"]
    deadline = time.monotonic() + 120
    while not all(f.exists() for f in files):
        assert parent.poll() is None and time.monotonic() < deadline, "the workers did not start"
        time.sleep(0.1)
    return parent, [int(f.read_text()) for f in files]


def _gone_within(pids: list[int], seconds: float) -> bool:
    deadline = time.monotonic() + seconds
    while any(alive(p) for p in pids) and time.monotonic() < deadline:
        time.sleep(0.1)
    return not any(alive(p) for p in pids)


def parent_of(pid: int) -> int:
    return int(Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[1])


@pytest.mark.parametrize("preload", [(), ("sleeper",)])  # with a preload (Linux): a fork server forked from the parent
@pytest.mark.parametrize("how", [signal.SIGKILL, signal.SIGINT])
def test_workers_end_with_their_parent(tmp_path, how, preload):
    parent, workers = _start_parent(tmp_path, preload)
    servers = {parent_of(p) for p in workers} - {parent.pid}
    try:
        assert all(alive(p) for p in workers)
        os.kill(parent.pid, how)
        assert parent.wait(timeout=30) == (-signal.SIGKILL if how == signal.SIGKILL else 130)
        assert _gone_within(workers, 5.0), f"workers still running 5 s after {how.name} of their parent"
        assert _gone_within(list(servers), 5.0), f"the fork server still runs 5 s after {how.name} of its parent"
    finally:
        for pid in [parent.pid, *workers, *servers]:
            if alive(pid):
                os.kill(pid, signal.SIGKILL)


def test_users_warnings_come_back_in_the_result_as_one_line():
    def stage():
        warnings.warn("cam0/video.mp4: video truncated\n  read up to frame 9", UserWarning, stacklevel=1)
        return {"message": "done"}

    called = call_recording_warnings(stage, {})
    assert called.value == {"message": "done"} and called.warnings == (
        "cam0/video.mp4: video truncated read up to frame 9",
    )
    assert SerialExecutor().submit(stage, {}).result().warnings == (
        "cam0/video.mp4: video truncated read up to frame 9",
    )


def where_and_square(value):
    """A part of a task run by run_each: which process ran it, and a result."""
    if value == 2:
        warnings.warn(f"part {value}: a warning for users", UserWarning, stacklevel=1)
    return {"pid": os.getpid(), "square": value * value}


def test_run_each_hands_the_parts_to_the_runs_workers_in_order():
    from tlsync_pipeline.pipeline.executors import ProcessExecutor, run_each

    executor = ProcessExecutor(2)
    try:
        executor.submit(where_and_square, {"value": 0}).result()  # a task started the pool
        results = run_each(executor, [(where_and_square, {"value": v}) for v in range(4)])
    finally:
        executor.close()
    assert [r.value["square"] for r in results] == [0, 1, 4, 9]
    assert all(r.value["pid"] != os.getpid() and r.elsewhere for r in results)  # in the pool's workers, not here
    assert all(r.cpu_s >= 0.0 for r in results)  # their CPU, for the task to count as its own
    assert results[2].warnings == ("part 2: a warning for users",) and results[1].warnings == ()
    serial = run_each(SerialExecutor(), [(where_and_square, {"value": 3})])
    assert (
        serial[0].value == {"pid": os.getpid(), "square": 9} and not serial[0].elsewhere
    )  # this process's CPU time counts it already


def test_run_each_does_not_start_a_pool_for_its_parts():
    """A pool no task has started stays unstarted: the parts run in this process (starting workers costs more than they
    do).
    """
    from tlsync_pipeline.pipeline.executors import ProcessExecutor, run_each

    executor = ProcessExecutor(2)
    try:
        results = run_each(executor, [(where_and_square, {"value": v}) for v in range(3)])
        assert not executor.started
    finally:
        executor.close()
    assert [(r.value["pid"], r.value["square"], r.elsewhere) for r in results] == [
        (os.getpid(), v * v, False) for v in range(3)
    ]
    assert results[2].warnings == ("part 2: a warning for users",)


PRELOADED = """
import os, time

with open({record!r}, "a") as handle:
    handle.write(f"{{os.getpid()}}\\n")
end = time.process_time() + {busy_s}
while time.process_time() < end:  # CPU the importing process spends, to be found in this test's children's
    pass
"""


def pid_and_modules(name):
    """A task: which process ran it and whether module ``name`` was already imported there."""
    import sys

    return {"pid": os.getpid(), "preloaded": name in sys.modules}


@pytest.mark.skipif(
    "forkserver" not in __import__("multiprocessing").get_all_start_methods(), reason="spawned workers import alone"
)
def test_workers_fork_from_one_process_that_imported_the_preload(tmp_path, monkeypatch):
    """The preload is imported once, by neither this process nor a worker, and every worker starts with it; once the
    pool is closed that process's CPU (and its workers') is this one's children's, as spawned workers' is."""
    import resource

    from tlsync_pipeline.pipeline.executors import ProcessExecutor

    record, busy_s = tmp_path / "imported_by", 0.3
    (tmp_path / "preloaded_marker.py").write_text(PRELOADED.format(record=str(record), busy_s=busy_s))
    monkeypatch.syspath_prepend(str(tmp_path))

    def children_cpu() -> float:
        usage = resource.getrusage(resource.RUSAGE_CHILDREN)
        return usage.ru_utime + usage.ru_stime

    before = children_cpu()
    executor = ProcessExecutor(2, preload=("preloaded_marker",))
    try:
        results = [executor.submit(pid_and_modules, {"name": "preloaded_marker"}).result().value for _ in range(4)]
    finally:
        executor.close()
    importers = [int(line) for line in record.read_text().split()]
    assert len(importers) == 1 and importers[0] != os.getpid()
    assert all(r["preloaded"] for r in results) and importers[0] not in {r["pid"] for r in results}
    assert "preloaded_marker" not in __import__("sys").modules  # this process never imported it
    assert children_cpu() - before >= busy_s


UNUSED_PARENT = """
import multiprocessing.forkserver, os, sys
sys.path.insert(0, {folder!r})
from tlsync_pipeline.pipeline.executors import ProcessExecutor

if __name__ == "__main__":
    executor = ProcessExecutor(2, preload=("unused_marker",))
    executor.fork_server()
    server = multiprocessing.forkserver._forkserver._forkserver_pid
    print("server", server, "forked here", open(f"/proc/{{server}}/stat").read().rsplit(")", 1)[1].split()[1] == str(os.getpid()))
    executor.close()
    try:
        os.kill(server, 0)
        print("ended at close", False)
    except ProcessLookupError:  # ended and reaped by the close
        print("ended at close", True)
"""


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="the fork server is forked from the run on Linux only")
def test_a_fork_server_no_task_started_ends_without_importing_the_preload(tmp_path):
    """The server forked before any task waits for a first task: closed before any, it imports nothing and ends with
    the close."""
    record = tmp_path / "imported_by"
    (tmp_path / "unused_marker.py").write_text(PRELOADED.format(record=str(record), busy_s=0.0))
    (tmp_path / "parent.py").write_text(UNUSED_PARENT.format(folder=str(tmp_path)))
    done = subprocess.run([sys.executable, str(tmp_path / "parent.py")], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    _, server, *said = done.stdout.split()
    assert said == ["forked", "here", "True", "ended", "at", "close", "True"], done.stdout
    assert not alive(int(server)) and not record.exists()


INHERITED_PARENT = """
import sys
sys.path.insert(0, {folder!r})
from tlsync_pipeline.pipeline.executors import ProcessExecutor


def task():
    import gc, os, sys
    return os.getpid(), "late_marker" in sys.modules, gc.isenabled(), gc.get_freeze_count() > 1000


if __name__ == "__main__":
    import os
    executor = ProcessExecutor(2, preload=("json",))
    import late_marker  # imported after the executor was made, before its server is forked
    executor.fork_server()
    executor.fork_server()  # forked once
    print(os.getpid(), *executor.submit(task, {{}}).result().value)
    executor.close()
"""


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="the fork server is forked from the run on Linux only")
def test_workers_inherit_what_the_run_imported_before_its_fork_server_was_forked(tmp_path):
    """The server is forked when the run asks (after its input checks): a module the run imported since it made the
    executor is in every worker without a worker or the server importing it again; the objects the worker inherited
    are frozen out of its garbage collections, which still run on its own."""
    record = tmp_path / "imported_by"
    (tmp_path / "late_marker.py").write_text(PRELOADED.format(record=str(record), busy_s=0.0))
    (tmp_path / "parent.py").write_text(INHERITED_PARENT.format(folder=str(tmp_path)))
    done = subprocess.run([sys.executable, str(tmp_path / "parent.py")], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    parent, worker, inherited, collecting, frozen = done.stdout.split()
    assert inherited == collecting == frozen == "True" and worker != parent
    assert [int(line) for line in record.read_text().split()] == [int(parent)]


OPENCV_PARENT = """
import sys, time
sys.path.insert(0, {folder!r})
import numpy as np, cv2
from tlsync_pipeline.pipeline.executors import ProcessExecutor
import sleeper

if __name__ == "__main__":
    cv2.resize(np.zeros((3000, 3000), np.uint8), (1000, 1000), interpolation=cv2.INTER_AREA)
    time.sleep(1.0)  # OpenCV's threads started, then waiting for work
    executor = ProcessExecutor(2, preload=("sleeper",))
    value = executor.submit(sleeper.blur, {{}}).result().value
    executor.close()
    print("blurred", value)
"""


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="the fork server is forked from the run on Linux only")
def test_a_fork_server_forked_after_opencv_started_its_threads_runs_opencv(tmp_path):
    """A run that used OpenCV's threads before its executor was made: the server forked from it, and its workers, still
    run OpenCV (a pool inherited without its threads would block their first call)."""
    (tmp_path / "sleeper.py").write_text(
        TASK + "\n\ndef blur():\n    import cv2, numpy as np\n"
        "    return int(cv2.GaussianBlur(np.full((2000, 2000), 7, np.uint8), (5, 5), 0).max())\n"
    )
    (tmp_path / "parent.py").write_text(OPENCV_PARENT.format(folder=str(tmp_path)))
    done = subprocess.run([sys.executable, str(tmp_path / "parent.py")], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0 and "blurred 7" in done.stdout, done.stderr


def test_a_ctrl_c_while_the_pool_starts_leaves_the_close_nothing_to_close_twice(monkeypatch):
    """Ctrl-C while the first task starts the pool, after the start pipe was handed over and closed: the close that
    follows (the interrupted run's) raises nothing (it closed the pipe again: "Bad file descriptor", exit 3)."""
    read_end, write_end = os.pipe()
    monkeypatch.setattr(executors, "can_fork_server", lambda: True)
    monkeypatch.setattr(executors, "fork_server_here", lambda preload: write_end)

    def interrupted(preload, start_server):
        os.close(start_server)
        raise KeyboardInterrupt

    monkeypatch.setattr(executors, "worker_context", interrupted)
    executor = executors.ProcessExecutor(2, preload=("json",))
    with pytest.raises(KeyboardInterrupt):
        executor.submit(len, {"obj": ()})
    executor.close(cancel=True)
    os.close(read_end)


def test_waiting_for_the_workers_stops_soon_after_a_stop_python_could_not_raise():
    """A Ctrl-C whose handler ran where Python cannot raise (a weakref callback, a finalizer) leaves only the stop
    asked: the run waiting for its workers raises KeyboardInterrupt within a poll, not once a task ends."""
    from tlsync_pipeline.pipeline import stop

    executor = executors.ProcessExecutor(1)
    try:
        future = executor.submit(subprocess.run, {"args": ["sleep", "5"]})
        try:
            stop.request_stop()
        except KeyboardInterrupt:
            pass  # swallowed where it ran
        start = time.monotonic()
        with pytest.raises(KeyboardInterrupt):
            executor.wait_any([future])
        assert time.monotonic() - start < 1.0
        assert not future.done()
    finally:
        stop.clear()
        executor.close(cancel=True)


def test_a_worker_whose_run_stopped_while_it_started_exits_without_a_traceback(capsys):
    """The fork server's children report an error before their first task through sys.excepthook: the EOFError of
    a run stopped while it handed a worker its start data is silent, any other error shown."""
    from tlsync_pipeline.pipeline.executors import quiet_when_the_run_is_gone

    quiet_when_the_run_is_gone(EOFError, EOFError("Ran out of input"), None)
    assert capsys.readouterr().err == ""
    quiet_when_the_run_is_gone(ValueError, ValueError("a worker's own error"), None)
    assert "ValueError: a worker's own error" in capsys.readouterr().err
