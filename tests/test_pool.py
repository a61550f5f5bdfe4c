"""The fan-out and its workers: sharing work, results in any order, a dead or stuck worker
lost alone, the guards every worker has (Ctrl-C ignored, memory limited, ended with its
parent), and no process left behind by `stackdsl check` however it ends."""

import ctypes
import itertools
import os
import re
import signal
import subprocess
import sys
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import ClassVar

import pytest

from stackdsl.batch import check as _check
from stackdsl.batch import guard as _guard
from stackdsl.batch import judge as _judge
from stackdsl.batch import pool as _pool
from stackdsl.cli.main import main

ROOT = Path(__file__).resolve().parents[1]
PASSING = "stackdsl: 1\nstructure: {tower: {levels: 2}}\nexpect: {stands: true}\n"
# About a second of CPU per second of settle: raw mode at 10 kHz steps every body every step.
SLOW = "stackdsl: 1\nstructure: {tower: {levels: 2}}\nengine: {mode: raw, timestep: 0.1 ms}\ntiming: {settle: %d s}\n"
QUICK = "stackdsl: 1\nstructure: {tower: {levels: 2}}\nengine: {mode: raw}\n"  # 1200 steps: its row comes first
two_cores = pytest.mark.skipif((os.cpu_count() or 1) < 2, reason="-j 2 needs two cores")


class ReadyWorkers(_pool.Workers):
    """Workers that are all ready before fan_out hands out anything, so that the longest
    task goes to a worker whatever the machine's load."""

    started: ClassVar[list["ReadyWorkers"]] = []

    def __init__(self, count, memory_limit=_guard.MEMORY_LIMIT, warm=None):
        super().__init__(count, memory_limit, warm)
        while self.ready < count:
            assert len(self.pids) == count, "a worker died while starting"
            self.collect(timeout=None)
        self.first_pids = set(self.pids)
        ReadyWorkers.started.append(self)


@pytest.fixture
def ready_workers(monkeypatch):
    ReadyWorkers.started = []
    monkeypatch.setattr(_pool, "Workers", ReadyWorkers)
    return ReadyWorkers.started


def alive(pid: int) -> bool:
    """The process exists and is not a zombie."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return stat.rsplit(")", 1)[1].split()[0] != "Z"


def descendants(pid: int) -> set[int]:
    """The living processes under ``pid``, from /proc."""
    parents = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if fields[0] != "Z":
                parents[int(entry.name)] = int(fields[1])
    found, frontier = set(), {pid}
    while frontier:
        frontier = {child for child, parent in parents.items() if parent in frontier} - found
        found |= frontier
    return found


def gone(pids: set[int], within: float = 30.0) -> set[int]:
    """The processes of ``pids`` still alive after waiting up to ``within`` seconds."""
    deadline = time.monotonic() + within
    while (left := {p for p in pids if alive(p)}) and time.monotonic() < deadline:
        time.sleep(0.1)
    return left


# sharing work


@pytest.mark.slow
def test_work_is_shared_with_the_workers(ready_workers):
    # Each task reports the process that ran it (sh's parent).
    task = (["sh", "-c", "sleep 0.1; echo $PPID"],)
    runners = [int(out) for out in _pool.fan_out(subprocess.check_output, [task] * 6, [1.0] * 6, jobs=2)]
    assert len(runners) == 6 and os.getpid() in runners and set(runners) - {os.getpid()} == ready_workers[0].first_pids


@pytest.mark.slow
def test_with_here_false_every_task_runs_in_a_worker_and_none_here(ready_workers):
    task = (["sh", "-c", "sleep 0.05; echo $PPID"],)
    runners = [int(out) for out in _pool.fan_out(subprocess.check_output, [task] * 8, [1.0] * 8, jobs=2, here=False)]
    workers = ready_workers[0].first_pids
    assert len(runners) == 8 and os.getpid() not in runners and set(runners) == workers and len(workers) == 2


def test_cheap_work_starts_no_worker(monkeypatch):
    def no_workers(count):
        raise AssertionError("started workers for work cheaper than their start-up")

    monkeypatch.setattr(_pool, "Workers", no_workers)
    assert list(_pool.fan_out(abs, [(-1,), (-2,)], [0.1, 0.1], jobs=2)) == [1, 2]


@pytest.mark.slow
def test_tasks_of_one_cost_are_read_as_they_are_handed_out(ready_workers):
    """An endless stream of tasks: the workers get them one by one, and closing the results
    after a few stops there (a list would never be built, let alone finished)."""
    taken = []

    def endless():
        for i in itertools.count():
            taken.append(i)
            yield (-i,)

    results = _pool.fan_out(abs, endless(), 1.0, jobs=2, here=False)
    got = [next(results) for _ in range(6)]
    results.close()
    assert len(set(got)) == 6 and set(got) <= set(taken) and len(taken) < 20


def test_an_executor_holds_at_most_its_window_of_an_endless_stream():
    taken = []

    def endless():
        for i in itertools.count():
            taken.append(i)
            yield (-i,)

    with ThreadPoolExecutor(2) as executor:
        results = _pool.on_executor(executor, abs, endless(), window=3)
        got = [next(results) for _ in range(5)]
        results.close()
    assert len(set(got)) == 5 and set(got) <= set(taken) and len(taken) <= 5 + 2 * 3  # done, not yet yielded, and running


@pytest.mark.slow
def test_closing_the_results_stops_the_workers(ready_workers):
    results = _pool.fan_out(os.getpid, [()] * 4, [1.0] * 4, jobs=2)
    first = next(results)
    pids = ready_workers[0].first_pids
    results.close()
    assert first in pids | {os.getpid()} and pids and not gone(pids, within=0)


def test_a_worker_imports_what_it_is_warmed_with_before_it_is_ready():
    """The pool is given the function its tasks run (fan_out passes its own), not a module name
    of its own to import: a worker imports that function's module, and only then says it is ready."""
    loaded = "'stackdsl.batch.judge' in __import__('sys').modules"
    for warm, expected in ((_judge.judge, True), (None, False)):
        workers = _pool.Workers(1, warm=warm)
        try:
            assert workers.run(eval, loaded) is expected
        finally:
            workers.stop()


def test_a_worker_ignores_ctrl_c_from_its_first_instruction():
    """A Ctrl-C to the whole group (``timeout -s INT``, a terminal) while a worker loads its
    modules stopped it with a "Fatal Python error" and a traceback: a spawned child does not keep
    the blocked mask it was started under. It is now started with SIGINT ignored, which a new
    program keeps: read from /proc at once, long before the worker's own guard runs."""
    workers = _pool.Workers(1)
    try:
        status = Path(f"/proc/{workers.pids[0]}/status").read_text()
        ignored = int(next(line.split()[1] for line in status.splitlines() if line.startswith("SigIgn:")), 16)
        assert ignored & (1 << (signal.SIGINT - 1))
        assert signal.getsignal(signal.SIGINT) is not signal.SIG_IGN  # this process has its own handler back
    finally:
        workers.stop()


def test_a_spare_worker_loads_first_and_the_next_pool_adopts_it(monkeypatch):
    """A spare (started before anything asked for it) calls its load before it says it is
    ready, and the next pool takes it in place of starting a worker of its own; a pool of
    another memory limit does not (it ends the spare and starts its own)."""
    from stackdsl import _entry

    monkeypatch.setattr(_pool, "_SPARES", [])
    _pool.start_spares(1, _entry.load_check)
    spare = _pool._SPARES[0][0].pid
    workers = _pool.Workers(1)
    try:
        assert workers.pids == [spare] and not _pool._SPARES
        assert workers.run(eval, "'stackdsl.batch.check_sweep' in __import__('sys').modules") is True
    finally:
        workers.stop()
    _pool.start_spares(1, _entry.load_check)
    spare = _pool._SPARES[0][0].pid
    workers = _pool.Workers(1, memory_limit=None)
    try:
        assert workers.pids != [spare] and not _pool._SPARES and not gone({spare}, within=10.0)
    finally:
        workers.stop()


@pytest.mark.slow
def test_an_exception_in_a_worker_comes_with_its_traceback():
    workers = _pool.Workers(1)
    try:
        with pytest.raises(ValueError, match="invalid literal") as info:
            workers.run(int, "x")
        assert isinstance(info.value.__cause__, _pool.RemoteTraceback) and "Traceback" in str(info.value.__cause__)
        assert workers.run(abs, -3) == 3  # the worker is still there
    finally:
        workers.stop()


# a worker lost: the others go on


@pytest.mark.slow
def test_a_dead_worker_loses_its_task_alone(ready_workers):
    # The costliest task goes to the (ready) worker, which it kills; the guard keeps the
    # kill from reaching this process if the task ever ran here.
    me = os.getpid()
    killer = (["sh", "-c", f'[ "$PPID" != {me} ] && kill -9 $PPID; echo $PPID'],)
    quick = (["sh", "-c", "echo $PPID"],)
    results = list(
        _pool.fan_out(
            subprocess.check_output, [quick, killer, quick], [1.0, 9.0, 1.0], jobs=2, lost=lambda task, error: (task, error)
        )
    )
    lost = [r for r in results if isinstance(r, tuple)]
    assert len(results) == 3 and [task for task, _ in lost] == [killer]
    error = lost[0][1]
    assert isinstance(error, _pool.WorkerDied) and error.signal == signal.SIGKILL
    assert str(error) == "worker died (SIGKILL, signal 9)"
    assert [int(r) for r in results if not isinstance(r, tuple)] == [me, me]


@pytest.mark.slow
def test_a_dead_worker_without_a_lost_callback_raises(ready_workers):
    me = os.getpid()
    killer = (["sh", "-c", f'[ "$PPID" != {me} ] && kill -9 $PPID; echo $PPID'],)
    with pytest.raises(_pool.WorkerDied):
        list(_pool.fan_out(subprocess.check_output, [killer, (["true"],)], [9.0, 1.0], jobs=2))


@pytest.mark.slow
def test_a_task_over_its_limit_ends_its_worker(ready_workers):
    results = list(_pool.fan_out(time.sleep, [(0,), (600,)], [1.0, 9.0], jobs=2, limit=0.5, lost=lambda task, error: error))
    (error,) = [r for r in results if r is not None]
    assert isinstance(error, _pool.WorkerTimedOut) and error.limit == 0.5
    assert str(error) == "still running after 0.5 s, worker stopped"
    assert not gone(ready_workers[0].first_pids, within=0)


@pytest.mark.slow
def test_a_dead_worker_is_its_scenarios_internal_error(tmp_path, ready_workers, monkeypatch, capsys):
    # The slow scenario goes to the worker, which is killed as soon as it has it.
    killed = []

    def kill_on_submit(self, fn, *args, limit=None):
        ticket = super(ReadyWorkers, self).submit(fn, *args, limit=limit)
        if not killed:
            killed.extend(self.pids)
            os.kill(killed[0], signal.SIGKILL)
        return ticket

    monkeypatch.setattr(ReadyWorkers, "submit", kill_on_submit, raising=False)
    (tmp_path / "a.yaml").write_text(PASSING)
    (tmp_path / "slow.yaml").write_text(SLOW % 600)
    (tmp_path / "z.yaml").write_text(PASSING)
    assert main(["check", str(tmp_path), "-j", "2"]) == 3
    captured = capsys.readouterr()
    rows = {Path(line.split()[1]).name: line for line in captured.out.splitlines() if line.startswith(("PASS", "FAIL"))}
    assert sorted(rows) == ["a.yaml", "slow.yaml", "z.yaml"]
    assert rows["slow.yaml"].startswith("FAIL")
    assert "internal error: worker died (SIGKILL, signal 9) running this scenario" in rows["slow.yaml"]
    assert rows["a.yaml"].startswith("PASS") and rows["z.yaml"].startswith("PASS")
    assert "3 scenarios: 2 passed, 1 failed (1 of them internal error)" in captured.out
    (line,) = said(captured.err)
    assert line.startswith("stackdsl: internal error: worker died") and line.endswith("(run with --debug for the traceback)")


# the guards in every worker


@pytest.mark.slow
def test_workers_ignore_ctrl_c_and_have_a_memory_limit():
    workers = _pool.Workers(1, memory_limit=3 * 2**30)
    try:
        assert workers.run(signal.getsignal, signal.SIGINT) == signal.SIG_IGN
        (pid,) = workers.pids
        limits = Path(f"/proc/{pid}/limits").read_text().splitlines()
        (line,) = [x for x in limits if x.startswith("Max address space")]
        assert line.split()[3] == str(3 * 2**30)
        with pytest.raises(MemoryError):
            workers.run(bytearray, 4 * 2**30)
        assert workers.run(abs, -1) == 1  # a MemoryError does not end the worker
    finally:
        workers.stop()


def test_out_of_memory_is_the_scenarios_internal_error(tmp_path, monkeypatch):
    def greedy(program, *args, **kwargs):
        raise MemoryError

    monkeypatch.setattr(_judge, "run_program", greedy)
    (tmp_path / "a.yaml").write_text(PASSING)
    (r,) = _check.check([tmp_path], jobs=1)
    assert not r.passed and r.error == "internal error: out of memory" and "MemoryError" in r.traceback
    assert r.expected == "stands" and r.measured == "internal error: out of memory"


@pytest.mark.slow
def test_a_worker_started_by_another_thread_outlives_that_thread():
    # The kernel's parent-death signal follows the starting thread: a worker started (and
    # ready) in a thread that then ends must go on, as a pool's replacement workers must.
    started = []

    def start():
        workers = _pool.Workers(1)
        started.append((workers, workers.run(os.getpid)))

    thread = threading.Thread(target=start)
    thread.start()
    thread.join()
    ((workers, pid),) = started
    try:
        assert workers.run(os.getpid) == pid and alive(pid)
    finally:
        workers.stop()


def test_other_pools_get_the_same_guards():
    with _guard.SPAWN.Pool(1) as pool:
        assert pool.apply(signal.getsignal, (signal.SIGINT,)) == signal.SIG_IGN
        pid = pool.apply(os.getpid)
        assert "Max address space" in Path(f"/proc/{pid}/limits").read_text()
        assert str(_guard.MEMORY_LIMIT) in Path(f"/proc/{pid}/limits").read_text()


# `stackdsl check -j 2` however it ends: nothing left behind


def said(err: str) -> list[str]:
    """The lines of a check's standard error, its progress lines aside (``check: 0 of 3 done
    (0%), 10 s``, every 10 s of a long check, on a loaded machine too)."""
    return [line for line in err.splitlines() if not re.match(r"check: \d+ of \d+ done", line)]


def start_check(tmp_path: Path) -> tuple[subprocess.Popen, Path, Path]:
    folder = tmp_path / "slow"
    folder.mkdir()
    (folder / "a_quick.yaml").write_text(QUICK)
    (folder / "b_slow.yaml").write_text(SLOW % 600)
    (folder / "c_slow.yaml").write_text(SLOW % 600)
    out, err = tmp_path / "out.txt", tmp_path / "err.txt"
    env = {**os.environ, "CI": "true"}
    with out.open("w") as stdout, err.open("w") as stderr:
        process = subprocess.Popen(
            [sys.executable, "-m", "stackdsl", "check", str(folder), "-j", "2"],
            stdout=stdout,
            stderr=stderr,
            env=env,
            cwd=ROOT,
            start_new_session=True,  # its own process group, for the Ctrl-C test
            preexec_fn=die_with_this_process,
        )
    return process, out, err


def die_with_this_process() -> None:
    """In the check's process before it starts: end it if the test run ends first (it has a
    session of its own, so a signal to the test run's group would miss it)."""
    ctypes.CDLL(None).prctl(_guard.PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)


def wait_for_workers(process: subprocess.Popen, out: Path) -> set[int]:
    """The check's processes once its first row is printed and its worker is started."""
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and process.poll() is None:
        below = descendants(process.pid)
        workers = [p for p in below if b"spawn_main" in Path(f"/proc/{p}/cmdline").read_bytes()]
        if workers and "PASS" in out.read_text():
            return below
        time.sleep(0.1)
    raise AssertionError(f"no worker and no first row within 120 s:\n{out.read_text()}")


@two_cores
@pytest.mark.parametrize("signum", [signal.SIGKILL, pytest.param(signal.SIGTERM, marks=pytest.mark.slow)])
def test_killing_check_leaves_no_process_behind(tmp_path, signum):
    process, out, err = start_check(tmp_path)
    try:
        below = wait_for_workers(process, out)
        assert len(below) >= 2  # a worker and multiprocessing's resource tracker
        os.kill(process.pid, signum)
        status = process.wait(60)
        assert status == (-signal.SIGKILL if signum == signal.SIGKILL else 128 + signal.SIGTERM)
        assert not gone(below), "processes left after the check ended"
        if signum == signal.SIGTERM:
            assert "Traceback" not in err.read_text()
    finally:
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait()


@two_cores
@pytest.mark.slow  # 4 s alone, 10 s beside other work: in .ci/nightly's slow part
def test_ctrl_c_is_one_line_exit_130_and_no_worker_left(tmp_path):
    process, out, err = start_check(tmp_path)
    try:
        below = wait_for_workers(process, out)
        os.killpg(process.pid, signal.SIGINT)  # as a terminal does: the whole process group
        assert process.wait(60) == 130
        assert said(err.read_text()) == ["stackdsl: interrupted"]
        assert not gone(below)
    finally:
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait()


def test_a_worker_that_fails_says_so_in_one_line(capfd, monkeypatch):
    monkeypatch.delenv("STACKDSL_TRACEBACK", raising=False)
    process = _guard.SPAWN.Process(target=int, args=("x",))
    process.start()
    process.join(120)
    assert process.exitcode == 1
    assert capfd.readouterr().err == (
        "stackdsl: internal error in a worker: ValueError: invalid literal for int() with base 10: 'x'"
        " (run with --debug for the traceback)\n"
    )


def test_auto_jobs_are_the_free_cores(monkeypatch):
    """-j auto: the cores less what other work keeps busy, at least 1: on a half-busy
    machine fewer processes than cores, on a saturated one a single process. Where the system
    has no count of running tasks, the 1-minute load average stands for it."""
    from stackdsl.batch import address
    from stackdsl.cli.args import jobs_type

    monkeypatch.setattr(address, "cores", lambda: 4)
    monkeypatch.setattr(address, "_running_others", lambda: None)
    for load, expected in ((0.0, 4), (1.4, 3), (2.0, 2), (3.6, 1), (40.0, 1)):
        monkeypatch.setattr(address.os, "getloadavg", lambda load=load: (load, load, load))
        assert jobs_type("auto") == expected, load


def test_auto_jobs_count_the_tasks_running_now_not_the_last_minute(monkeypatch):
    """The load average lags by a minute: an install just before a check left it near 1 on an
    idle 2-core machine, and -j auto ran one process. The tasks running now decide, the
    median of a few looks (one look that catches a passing task does not)."""
    from stackdsl.batch import address

    monkeypatch.setattr(address, "cores", lambda: 2)
    monkeypatch.setattr(address.os, "getloadavg", lambda: (0.9, 0.5, 0.2))  # the install's, just ended
    looks = iter([0, 1, 0])
    monkeypatch.setattr(address, "_running_others", lambda: next(looks))
    assert address.free_cores() == 2
    monkeypatch.setattr(address, "_running_others", lambda: 1)  # another process busy on a core now
    monkeypatch.setattr(address.os, "getloadavg", lambda: (0.05, 0.01, 0.0))  # started a moment ago
    assert address.free_cores() == 1


def test_the_running_tasks_are_read_from_the_kernel_less_this_process():
    """On Linux the count is read (this process's own runnable threads left out): never negative."""
    from stackdsl.batch import address

    if not os.path.exists("/proc/loadavg"):
        pytest.skip("no /proc/loadavg on this system: the load average stands for it")
    running = address._running_others()
    assert running is not None and running >= 0
