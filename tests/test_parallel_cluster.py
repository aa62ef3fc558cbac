"""A two-node Ray cluster on loopback (head 127.0.0.2, worker node 127.0.0.3, token authentication on), joined
by address: the cases give the serial results, and a worker node killed mid-batch loses nothing. Slow (about a
minute): each node is ``ray start --block`` in its own process group, ended by killing the group."""

from __future__ import annotations

import os
import re
import secrets
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import pytest

from magsoft_env.parallel import comparable, run_batch

# one pytest-xdist worker (--dist loadgroup) starts the Ray clusters of this module and tests/test_parallel.py
pytestmark = [pytest.mark.slow, pytest.mark.xdist_group("ray")]

CASES = [
    *({"kind": "equilibrium", "robot": "paper-5c", "field_mT": [0.0, b]} for b in (1.0, 3.0, 5.0, 7.0)),
    {"kind": "equilibrium", "robot": "paper-5c", "field_mT": [1.0, 2.0, 3.0]},
    {"kind": "gait", "robot": "paper-5c", "seconds": 0.3},
    {"kind": "equilibrium", "robot": "paper-5c", "field_mT": [0.0, 1.0, 2.0, 3.0]},  # bad: a failure row
]


def _ray_cli() -> str:
    exe = Path(sys.executable).with_name("ray")
    return str(exe) if exe.exists() else shutil.which("ray")


def _node(args, log: Path, env) -> subprocess.Popen:
    with open(log, "w") as fh:
        return subprocess.Popen([_ray_cli(), "start", *args, "--num-cpus", "1", "--object-store-memory",
                                 str(80 * 2**20), "--disable-usage-stats", "--block"],
                                stdout=fh, stderr=subprocess.STDOUT, env=env, start_new_session=True)


def _end(proc: subprocess.Popen):
    """Kill the node's process group (raylet, GCS, agents: all of it), politely first."""
    for sig, wait in ((signal.SIGTERM, 10), (signal.SIGKILL, 10)):
        try:
            os.killpg(proc.pid, sig)
        except ProcessLookupError:
            return
        try:
            proc.wait(wait)
        except subprocess.TimeoutExpired:
            continue
        # the group may outlive its leader
        time.sleep(0.5)
    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except ProcessLookupError:
        pass


def _wait_for(log: Path, pattern: str, seconds: float) -> re.Match:
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        m = re.search(pattern, log.read_text(errors="replace")) if log.exists() else None
        if m:
            return m
        time.sleep(0.2)
    raise AssertionError(f"{log.name}: no {pattern!r} within {seconds} s:\n{log.read_text(errors='replace')[-3000:]}")


@pytest.fixture
def cluster(tmp_path, monkeypatch):
    pytest.importorskip("ray")
    if _ray_cli() is None:
        pytest.skip("the ray command is not installed")
    token = tmp_path / "token"
    token.write_text(secrets.token_hex(32))
    root = Path(tempfile.mkdtemp(prefix="rt", dir="/tmp"))  # short: Ray's socket paths must fit 107 bytes
    env = {**os.environ, "RAY_AUTH_MODE": "token", "RAY_AUTH_TOKEN_PATH": str(token),
           "PYTHONPATH": os.pathsep.join([str(Path(__file__).resolve().parents[1]), os.environ.get("PYTHONPATH", "")])}
    env.pop("RAY_ADDRESS", None)
    nodes = []
    try:
        nodes.append(_node(["--head", "--node-ip-address", "127.0.0.2", "--port", "0", "--include-dashboard",
                            "false", "--temp-dir", str(root)], tmp_path / "head.log", env))
        address = _wait_for(tmp_path / "head.log", r"--address='(127\.0\.0\.2:\d+)'", 90).group(1)
        nodes.append(_node(["--address", address, "--node-ip-address", "127.0.0.3"], tmp_path / "worker.log", env))
        _wait_for(tmp_path / "worker.log", r"Ray runtime started", 90)
        monkeypatch.delenv("RAY_AUTH_MODE", raising=False)  # the engine sets it, and puts it back
        yield {"address": address, "token": str(token), "worker": nodes[1]}
    finally:
        for proc in reversed(nodes):
            _end(proc)
        shutil.rmtree(root, ignore_errors=True)


def test_two_nodes_give_the_serial_results_and_a_killed_node_loses_nothing(cluster, tmp_path):
    serial = run_batch(CASES, tmp_path / "serial.jsonl", engine="serial")
    opts = {"auth_token_file": cluster["token"]}
    res = run_batch(CASES, tmp_path / "ray.jsonl", engine="ray", address=cluster["address"], ray_options=opts)
    assert [comparable(r) for r in res.rows] == [comparable(r) for r in serial.rows]
    assert res.failed == 1 and "RAY_AUTH_MODE" not in os.environ

    # both nodes busy with 1 s cases; the worker node is killed (its whole process group) during the batch
    cases = [{"kind": "sleep", "seconds": 1.0, "tags": [i]} for i in range(8)]
    box = {}
    t = threading.Thread(target=lambda: box.update(res=run_batch(
        cases, tmp_path / "killed.jsonl", engine="ray", address=cluster["address"], ray_options=opts, retries=3)))
    t0 = time.monotonic()
    t.start()
    time.sleep(4.0)  # the driver joined and both nodes run cases
    os.killpg(cluster["worker"].pid, signal.SIGKILL)
    t.join(150)
    assert not t.is_alive()
    res = box["res"]
    assert res.ok == 8 and [r["case"]["tags"] for r in res.rows] == [[i] for i in range(8)]
    assert time.monotonic() - t0 < 150
