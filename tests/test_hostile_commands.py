"""Hostile and careless command lines end cleanly: the cases in tests/hostile/commands/cases.yaml.

Each case runs ``python -m stackdsl ARGS`` as its own process in a fresh folder holding the
files it lists, with a private ``TMPDIR``, and must end with its exit status, print what it
``says`` on stderr in a short message without a traceback, leave none of the files it names
under ``absent`` (``make`` makes odd files first: a FIFO, zips), ``stdout: closed`` or ``stderr: closed``
closing that stream before it starts, peak under 2 GB of resident memory, and leave nothing in ``TMPDIR`` when it
refused its input (exit 2). ``env`` adds to the environment; ``tool: pytest`` runs ``python -m pytest ARGS``
instead (the plugin's project tolerances). The
cases cover the sweep's options and language, ``--dask``, drawings, ``--record`` and
trajectory files, check's outputs, each engine's own limits and refused paths. Marker
``slow`` (.ci/nightly runs them)::

    .venv/bin/python -m pytest -m slow tests/test_hostile_commands.py

Source: stackdsl's own.
"""

from __future__ import annotations

import http.server
import io
import os
import resource
import socket
import subprocess
import sys
import tempfile
import threading
import time
import zipfile
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

ROOT = Path(__file__).resolve().parents[1]
HERE = ROOT / "tests" / "hostile" / "commands"
CASES = yaml.safe_load((HERE / "cases.yaml").read_text())["cases"]
#: Round five's cases (fresh.yaml), checked more strictly: TMPDIR left empty whatever the exit,
#: nothing new in the repository, and the case's own peak resident memory under FRESH_MEMORY_LIMIT.
FRESH = yaml.safe_load((HERE / "fresh.yaml").read_text())["cases"]
for _case in FRESH:
    _case["fresh"] = True
CASES += FRESH
TIMEOUT = 120.0  # s, per case
MEMORY_LIMIT = 2 << 30  # bytes of peak resident memory a case may use
FRESH_MEMORY_LIMIT = 1536 << 20  # bytes: a fresh case's own peak (its process and the workers it waited for)


def empty_zip(path: Path) -> None:
    with zipfile.ZipFile(path, "w"):
        pass


def foreign_npz(path: Path) -> None:
    np.savez(path, weights=np.arange(6.0).reshape(2, 3))


def pickled_npz(path: Path) -> None:
    with zipfile.ZipFile(path, "w") as z:
        z.writestr("meta.npy", _npy_of_objects())


def _npy_of_objects() -> bytes:
    out = io.BytesIO()
    np.save(out, np.array([{"a": 1}], dtype=object), allow_pickle=True)
    return out.getvalue()


def fifo(path: Path) -> None:
    os.mkfifo(path)  # opened by a writer, it would block until something reads it


def sparse_17_mib(path: Path) -> None:
    with open(path, "wb") as f:
        f.truncate(17 << 20)  # its size says it all; nothing need be read


def sparse_65_mib(path: Path) -> None:
    with open(path, "wb") as f:
        f.truncate(65 << 20)  # a trajectory file past its 64 MiB


MAKERS = {
    "empty_zip": empty_zip,
    "foreign_npz": foreign_npz,
    "pickled_npz": pickled_npz,
    "fifo": fifo,
    "sparse_17_mib": sparse_17_mib,
    "sparse_65_mib": sparse_65_mib,
}


@pytest.fixture(scope="module")
def http_port():
    """A local HTTP server: something that answers, but is not a Dask scheduler."""
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), http.server.SimpleHTTPRequestHandler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    yield server.server_address[1]
    server.shutdown()


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


GRID_BOMB = "stackdsl: 1\nstructure: {tower: {levels: 2}}\nsweep:\n  samples: 1\n  grid:\n" + "".join(
    f"    {key}: [{', '.join(str(v) for v in range(1, 101))}]\n"
    for key in ("structure.tower.levels", "stability.rest_duration", "timing.settle")
)


def test_the_cases_are_many_and_named_once():
    names = [c["name"] for c in CASES]
    assert len(names) >= 100 and len(set(names)) == len(names)
    assert len(FRESH) >= 100


def _repository() -> str:
    """What git sees changed or new in the repository (a fresh case must leave it as it was)."""
    done = subprocess.run(
        ["git", "-C", str(ROOT), "status", "--porcelain", "--untracked-files=all"], capture_output=True, text=True, check=False
    )
    return done.stdout


@pytest.mark.slow
@pytest.mark.parametrize("case", CASES, ids=[c["name"] for c in CASES])
def test_a_hostile_command_ends_cleanly(case, tmp_path, http_port):
    work, scratch = tmp_path / "work", tmp_path / "scratch"
    work.mkdir()
    scratch.mkdir()
    values = {
        "long": "x" * 300,
        "deep_k": "(" * 500 + "t" + ")" * 500,
        "free_port": str(free_port()),
        "http_port": str(http_port),
        "grid_bomb": GRID_BOMB,
        "grid_deep": "[" * 100_000 + "]" * 100_000,
    }

    def fill(text: str) -> str:
        for key, value in values.items():
            text = text.replace("{" + key + "}", value)
        return text

    for name, text in (case.get("files") or {}).items():
        target = work / name
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_text(fill(text))
    for name, maker in (case.get("make") or {}).items():
        (work / name).parent.mkdir(parents=True, exist_ok=True)
        MAKERS[maker](work / name)
    args = [fill(a) for a in case["args"]]
    env = {**os.environ, "TMPDIR": str(scratch), "COLUMNS": "120", **(case.get("env") or {})}
    env.pop("STACKDSL_TRACEBACK", None)
    stdout: int | io.BufferedWriter = subprocess.PIPE
    closed = case.get("stdout") == "closed"
    if case.get("stdout") == "/dev/full":
        stdout = open("/dev/full", "wb")
    repository = _repository() if case.get("fresh") else ""
    try:
        done = _run(
            [sys.executable, "-m", case.get("tool", "stackdsl"), *args],
            cwd=work,
            env=env,
            stdout=subprocess.DEVNULL if closed else stdout,
            preexec_fn=(lambda: os.close(1)) if closed else (lambda: os.close(2)) if case.get("stderr") == "closed" else None,
        )
    finally:
        if not isinstance(stdout, int):
            stdout.close()
    err = done.stderr.decode(errors="replace")
    out = (done.stdout or b"").decode(errors="replace")
    allowed = case["exit"] if isinstance(case["exit"], list) else [case["exit"]]
    assert done.returncode in allowed, f"exit {done.returncode}\n{err}"
    assert "Traceback" not in err + out, err
    if case.get("says"):  # pytest (tool: pytest) says a failed item's message on stdout
        assert case["says"] in (err + out if case.get("tool") == "pytest" else err), err + out
    if done.returncode == 2:
        assert 0 < len(err.strip().splitlines()) <= 8, err
        assert not any(scratch.iterdir()), sorted(p.name for p in scratch.iterdir())
    # the largest resident set of any process this one has waited for (cases, and their workers)
    assert resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss * 1024 < MEMORY_LIMIT
    for name in case.get("absent", []):
        assert not (work / name).exists(), name
        assert not [p for p in work.iterdir() if p.name.startswith(f".{name}")], "a part-file was left"
    for name in case.get("present", []):
        assert (work / name).is_file(), name
    for name, text in (case.get("forbid") or {}).items():
        assert not (work / name).exists() or text not in (work / name).read_text(errors="replace"), f"{name} holds {text!r}"
    if case.get("fresh"):
        print(f"fresh case {case['name']}: exit {done.returncode}, peak {done.peak >> 20} MiB")
        assert done.peak < FRESH_MEMORY_LIMIT, f"{done.peak >> 20} MiB"
        assert not any(scratch.iterdir()), sorted(p.name for p in scratch.iterdir())
        assert _repository() == repository, "the case changed the repository"


class _Done(subprocess.CompletedProcess[bytes]):
    peak: int  # bytes: the case's own largest resident set (its process and the children it waited for)


def _run(argv: list[str], stdout: Any, **popen: Any) -> _Done:
    """``argv`` as a process, as ``subprocess.run`` with stderr piped, killed after TIMEOUT; with
    the case's own peak memory, from ``wait4`` (getrusage of the children is the largest of all cases)."""
    with tempfile.TemporaryFile() as out, tempfile.TemporaryFile() as err:
        proc = subprocess.Popen(
            argv, stdin=subprocess.DEVNULL, stdout=out if stdout is subprocess.PIPE else stdout, stderr=err, **popen
        )
        start = time.monotonic()
        while True:
            pid, status, usage = os.wait4(proc.pid, os.WNOHANG)
            if pid:
                break
            if time.monotonic() - start > TIMEOUT:
                proc.kill()
                os.wait4(proc.pid, 0)
                raise subprocess.TimeoutExpired(argv, TIMEOUT)
            time.sleep(0.02)
        proc.returncode = os.waitstatus_to_exitcode(status)
        out.seek(0)
        err.seek(0)
        done = _Done(argv, proc.returncode, out.read() if stdout is subprocess.PIPE else None, err.read())
        done.peak = usage.ru_maxrss * 1024
        return done
