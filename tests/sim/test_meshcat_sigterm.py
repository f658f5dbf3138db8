"""--meshcat stopped by SIGTERM (kill, a job scheduler) stops meshcat's server process too,
as Ctrl-C does (issue 21): no stray server is left behind."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest


def _children(pid: int) -> list[int]:
    out = subprocess.run(["ps", "-o", "pid=", "--ppid", str(pid)], capture_output=True,
                         text=True).stdout  # fmt: skip
    return [int(x) for x in out.split()]


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    state = subprocess.run(["ps", "-o", "stat=", "-p", str(pid)], capture_output=True,
                           text=True).stdout.strip()  # fmt: skip
    return bool(state) and not state.startswith("Z")


@pytest.mark.skipif(sys.platform != "linux", reason="uses ps --ppid")
def test_sigterm_stops_the_meshcat_server(tmp_path):
    cmd = [sys.executable, "-m", "ffsm_pin.sim", "--case", "1", "--duration", "0.2",
           "--meshcat", "--no-plots", "--no-html", "--out", str(tmp_path / "out")]  # fmt: skip
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    try:
        deadline = time.monotonic() + 300
        line = ""
        while "meshcat: open the URL" not in line:  # the server is up and serving
            line = proc.stdout.readline()
            assert line or proc.poll() is None, "the CLI ended before serving"
            assert time.monotonic() < deadline
        servers = _children(proc.pid)
        assert servers and all(_alive(p) for p in servers)
        proc.send_signal(signal.SIGTERM)
        proc.wait(timeout=60)
        time.sleep(0.5)
        assert not [p for p in servers if _alive(p)], "meshcat's server outlived the CLI"
    finally:
        if proc.poll() is None:
            proc.kill()
