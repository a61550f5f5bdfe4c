"""A real Dask cluster, started with Dask's own CLI (``dask scheduler``, ``dask worker``) on
127.0.0.1, that loses a worker in the middle of a sweep: every sample still comes back, the
same as with one process, and the sweep says which worker left."""

from __future__ import annotations

import csv
import os
import shutil
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DASK = Path(sys.executable).with_name("dask")

pytestmark = [
    pytest.mark.slow,
    pytest.mark.skipif(not DASK.exists(), reason="Dask's CLI is not installed (pip install 'stackdsl[dask]')"),
]


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def wait_for(port: int, seconds: float = 30.0) -> None:
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        with socket.socket() as s:
            if s.connect_ex(("127.0.0.1", port)) == 0:
                return
        time.sleep(0.2)
    raise TimeoutError(f"nothing listens at 127.0.0.1:{port}")


def rows(path: Path) -> list[dict[str, str]]:
    """samples.csv without the wall-time column (a measurement, different in every run)."""
    with path.open() as f:
        return [{k: v for k, v in row.items() if k != "wall_time"} for row in csv.DictReader(f)]


def test_a_sweep_on_a_real_cluster_that_loses_a_worker_gives_every_sample(tmp_path):
    scenario = ROOT / "sweeps" / "random_single_file.yaml"
    port = free_port()
    env = {**os.environ, "DASK_DISTRIBUTED__WORKER__DAEMON": "False"}
    quiet = {"stdout": subprocess.DEVNULL, "stderr": subprocess.DEVNULL, "cwd": tmp_path, "env": env}
    scheduler = subprocess.Popen([str(DASK), "scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard"], **quiet)
    workers: list[subprocess.Popen[bytes]] = []
    try:
        wait_for(port)
        for name in ("w1", "w2"):
            command = [str(DASK), "worker", f"tcp://127.0.0.1:{port}", "--nthreads", "1", "--no-nanny", "--no-dashboard"]
            workers.append(subprocess.Popen([*command, "--name", name], **quiet))
        time.sleep(3.0)  # both workers registered
        out = tmp_path / "dask"
        sweep = subprocess.Popen(
            [sys.executable, "-m", "stackdsl", "sweep", str(scenario), "--samples", "300", "--dask", f"tcp://127.0.0.1:{port}"]
            + ["--out", str(out)],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        time.sleep(6.0)  # the sweep is running on both workers
        assert sweep.poll() is None, "the sweep ended before a worker could be killed: give it more samples"
        workers[0].send_signal(signal.SIGKILL)
        _, stderr = sweep.communicate(timeout=300)
        assert sweep.returncode in (0, 1), stderr  # 1: a statistical expectation not met, not a failure
        assert "1 Dask worker left during the sweep" in stderr and "every sample is in the results" in stderr
        local = tmp_path / "local"
        subprocess.run(
            [sys.executable, "-m", "stackdsl", "sweep", str(scenario), "--samples", "300", "-j", "1", "--out", str(local)],
            capture_output=True,
            timeout=300,
            check=False,
        )
        on_cluster, alone = rows(out / "samples.csv"), rows(local / "samples.csv")
        assert len(on_cluster) == 300 and on_cluster == alone
    finally:
        for process in [*workers, scheduler]:
            process.kill()
            process.wait(timeout=30)
        shutil.rmtree(tmp_path / "dask-scratch-space", ignore_errors=True)


def start_cluster(tmp_path: Path, port: int, workers: int) -> list[subprocess.Popen[bytes]]:
    """A scheduler on 127.0.0.1:port and ``workers`` single-thread workers without a nanny (the
    scheduler first in the list)."""
    env = {**os.environ, "DASK_DISTRIBUTED__WORKER__DAEMON": "False"}
    quiet: dict[str, object] = {"stdout": subprocess.DEVNULL, "stderr": subprocess.DEVNULL, "cwd": tmp_path, "env": env}
    started = [subprocess.Popen([str(DASK), "scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard"], **quiet)]
    wait_for(port)
    for _ in range(workers):
        started.append(start_worker(tmp_path, port))
    time.sleep(3.0)  # the workers registered
    return started


def start_worker(tmp_path: Path, port: int) -> subprocess.Popen[bytes]:
    env = {**os.environ, "DASK_DISTRIBUTED__WORKER__DAEMON": "False"}
    command = [str(DASK), "worker", f"tcp://127.0.0.1:{port}", "--nthreads", "1", "--no-nanny", "--no-dashboard"]
    return subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, cwd=tmp_path, env=env)


def start_sweep(port: int, out: Path, samples: int = 300) -> subprocess.Popen[str]:
    scenario = ROOT / "sweeps" / "random_single_file.yaml"
    command = [sys.executable, "-m", "stackdsl", "sweep", str(scenario), "--samples", str(samples)]
    return subprocess.Popen(
        [*command, "--dask", f"tcp://127.0.0.1:{port}", "--out", str(out)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, "STACKDSL_PROGRESS_SECONDS": "1"},
    )


def test_a_scheduler_that_goes_away_mid_sweep_is_one_line_and_exit_3(tmp_path):
    port = free_port()
    cluster = start_cluster(tmp_path, port, workers=1)
    try:
        out = tmp_path / "out"
        sweep = start_sweep(port, out, samples=600)
        time.sleep(6.0)
        assert sweep.poll() is None, "the sweep ended before the scheduler could be killed: give it more samples"
        cluster[0].send_signal(signal.SIGKILL)
        _, stderr = sweep.communicate(timeout=120)
        said = [line for line in stderr.splitlines() if not line.startswith("sweep: ")]  # the progress lines aside
        assert sweep.returncode == 3, stderr
        assert "Traceback" not in stderr and "distributed" not in stderr, stderr
        assert len(said) == 1, stderr
        assert said[0].startswith(f"stackdsl: the Dask scheduler at tcp://127.0.0.1:{port} went away after "), stderr
        assert "of 600 samples" in said[0]
        assert not (out / "samples.csv").exists()
    finally:
        for process in cluster:
            process.kill()
            process.wait(timeout=30)
        shutil.rmtree(tmp_path / "dask-scratch-space", ignore_errors=True)


def test_a_cluster_with_no_worker_left_says_so_and_waits_for_one(tmp_path):
    port = free_port()
    cluster = start_cluster(tmp_path, port, workers=1)
    try:
        out = tmp_path / "out"
        sweep = start_sweep(port, out)
        time.sleep(6.0)
        assert sweep.poll() is None, "the sweep ended before its worker could be killed: give it more samples"
        cluster[1].send_signal(signal.SIGKILL)
        assert sweep.stderr is not None
        end, waiting = time.monotonic() + 60, ""
        while time.monotonic() < end and not waiting:
            line = sweep.stderr.readline()
            if "no worker connected to the scheduler" in line:
                waiting = line
        assert waiting.startswith("sweep: ") and "left" not in waiting, waiting  # no growing time left either
        cluster.append(start_worker(tmp_path, port))
        _, rest = sweep.communicate(timeout=300)
        assert sweep.returncode in (0, 1), rest
        assert len(rows(out / "samples.csv")) == 300
        assert "Traceback" not in rest
    finally:
        for process in cluster:
            process.kill()
            process.wait(timeout=30)
        shutil.rmtree(tmp_path / "dask-scratch-space", ignore_errors=True)
