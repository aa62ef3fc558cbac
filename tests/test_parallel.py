"""Batches of cases on the serial, local and Ray engines: the same results everywhere (every field but wall time),
failure rows, timeouts, a killed worker, resume, generators, the ``magsoft batch`` command, and no Ray import
where none is asked for."""

from __future__ import annotations

import importlib.util
import json
import os
import signal
import subprocess
import sys
import textwrap
import threading
import time
from pathlib import Path

import pytest

from magsoft_env.cli import main
from magsoft_env.parallel import (
    LocalEngine,
    case_ids,
    comparable,
    read_cases,
    read_results,
    run_batch,
    sweeps,
    write_cases,
)

ROOT = Path(__file__).resolve().parents[1]
#: the tests that start a Ray, on one pytest-xdist worker (``--dist loadgroup``), as tests/test_parallel_cluster.py
ray_group = pytest.mark.xdist_group("ray")

CASES = [
    *({"kind": "equilibrium", "robot": "paper-5c", "field_mT": [0.0, b]} for b in (1.0, 4.0, 7.0)),
    {"kind": "equilibrium", "robot": "paper-5c", "field_mT": [0.0, 2.0, 3.0]},  # the 3D rod
    {"kind": "equilibrium", "robot": "paper-5c", "field_mT": [0.0, 5.0], "scale": {"E0": 1.1, "thickness": 0.95}},
    {"kind": "path", "robot": "paper-5a", "field_mT": [0.0, 6.0], "steps": 4},
    {"kind": "gait", "robot": "paper-5c", "seconds": 0.3, "reverse": True},
    {"kind": "equilibrium", "robot": "no-such-robot"},  # a bad case: a failure row
    {"kind": "sleep", "raise": "a job that raises"},
]


def _comparable(rows):
    return [comparable(r) for r in rows]


@pytest.fixture(scope="module")
def serial_rows(tmp_path_factory):
    res = run_batch(CASES, tmp_path_factory.mktemp("serial") / "r.jsonl", engine="serial")
    assert (res.ok, res.failed, res.ran) == (7, 2, 9)
    return res.rows


def test_serial_rows_hold_the_case_and_its_result_or_its_error(serial_rows):
    assert [r["index"] for r in serial_rows] == list(range(len(CASES)))
    assert [r["case"] for r in serial_rows] == CASES
    bad = serial_rows[7]
    assert not bad["ok"] and bad["error"]["type"] == "ValueError" and "no-such-robot" in bad["error"]["message"]
    assert serial_rows[8]["error"]["message"] == "a job that raises"
    assert serial_rows[3]["result"]["tip_position_m"]  # a 3D equilibrium
    assert len(serial_rows[5]["result"]["states"]) == 4
    assert serial_rows[6]["result"]["direction"] in ("left", "right", "none", "tumble")
    assert all("wall_time_s" not in json.dumps(r.get("result", {})) for r in serial_rows)


def test_local_pool_gives_the_serial_results(serial_rows, tmp_path):
    out = tmp_path / "r.jsonl"
    res = run_batch(CASES, out, engine="local", workers=2)
    assert _comparable(res.rows) == _comparable(serial_rows)
    assert _comparable(read_results(out)) == _comparable(serial_rows)  # the file, in the cases' order


@ray_group
def test_in_process_ray_gives_the_serial_results(serial_rows, tmp_path):
    pytest.importorskip("ray")
    res = run_batch(CASES, tmp_path / "r.jsonl", engine="ray", workers=2)
    assert _comparable(res.rows) == _comparable(serial_rows)
    import ray

    assert not ray.is_initialized()  # the private Ray ended with the batch


@ray_group
def test_a_case_past_its_timeout_is_a_failure_row_and_the_rest_run(tmp_path):
    # generous limits: the other tests may load the cores (a Ray start then takes tens of seconds)
    cases = [{"kind": "sleep", "seconds": 300}, {"kind": "sleep", "seconds": 0.01}, {"kind": "sleep"}]
    engines = ("serial", "local") + (("ray",) if importlib.util.find_spec("ray") else ())
    for engine in engines:
        t0 = time.monotonic()
        res = run_batch(cases, tmp_path / f"{engine}.jsonl", engine=engine, workers=2, timeout=3)
        assert time.monotonic() - t0 < 150, engine  # not the 300 s of the first case
        assert [r["ok"] for r in res.rows] == [False, True, True], (engine, res.rows)
        assert res.rows[0]["error"]["type"] == "CaseTimeout"
        assert comparable(res.rows[0])["error"]["message"] == "the case ran longer than the timeout of 3 s"


def test_a_killed_local_worker_loses_nothing(tmp_path):
    cases = [{"kind": "sleep", "seconds": 0.4, "tags": [i]} for i in range(6)]
    engine = LocalEngine(2)
    box = {}
    t = threading.Thread(target=lambda: box.update(res=run_batch(cases, tmp_path / "r.jsonl", engine=engine)))
    t.start()
    deadline = time.monotonic() + 30
    while not engine.pids and time.monotonic() < deadline:
        time.sleep(0.05)
    time.sleep(0.2)  # both workers inside their first case
    os.kill(engine.pids[0], signal.SIGKILL)
    t.join(60)
    res = box["res"]
    assert res.ok == 6 and res.failed == 0
    assert [r["case"]["tags"] for r in res.rows] == [[i] for i in range(6)]


def test_a_worker_that_always_dies_becomes_a_failure_row(tmp_path):
    # a case that kills its worker each time: retried, then a WorkerDied row; the others are done
    cases = [{"kind": "sleep", "seconds": 0.05}, {"kind": "sleep", "seconds": 5.0, "tags": ["victim"]}]
    engine = LocalEngine(1)
    box = {}
    t = threading.Thread(target=lambda: box.update(
        res=run_batch(cases, tmp_path / "r.jsonl", engine=engine, retries=1, chunk_size=1)))
    t.start()
    killed = set()
    while t.is_alive():
        rows = read_results(tmp_path / "r.jsonl")
        if len(rows) >= 1:  # the first case is done: the worker now runs the victim, kill it each time
            for pid in engine.pids:
                if pid not in killed:
                    killed.add(pid)
                    try:
                        os.kill(pid, signal.SIGKILL)
                    except ProcessLookupError:
                        pass
        time.sleep(0.01)
    res = box["res"]
    assert res.rows[0]["ok"] and len(killed) == 2  # the first run of the victim and its one retry
    assert res.rows[1]["error"]["type"] == "WorkerDied" and "2 times" in res.rows[1]["error"]["message"]


_INTERRUPTED = textwrap.dedent("""
    import sys
    from magsoft_env.parallel import run_batch

    if __name__ == "__main__":
        cases = [{"kind": "sleep", "seconds": 0.3, "tags": [i]} for i in range(40)]
        run_batch(cases, sys.argv[1], engine="local", workers=1)
""")


def test_an_interrupted_batch_resumes_without_redoing_finished_cases(tmp_path):
    out = tmp_path / "r.jsonl"
    script = tmp_path / "driver.py"
    script.write_text(_INTERRUPTED)
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.Popen([sys.executable, str(script), str(out)], env=env, start_new_session=True)
    try:
        deadline = time.monotonic() + 60
        while (not out.exists() or len(read_results(out)) < 3) and time.monotonic() < deadline:
            time.sleep(0.05)
    finally:
        os.killpg(proc.pid, signal.SIGKILL)  # the driver and its workers, at once
        proc.wait()
    with open(out, "a") as fh:
        fh.write('{"index": 5, "id": "half a li')  # a row cut short
    before = read_results(out)
    assert 3 <= len(before) < 40
    cases = [{"kind": "sleep", "seconds": 0.0, "tags": [i]} for i in range(40)]
    # the same ids: the first cases' rows are kept (their 0.3 s wall times), the rest run now
    cases = [{**c, "id": cid} for c, cid in zip(cases, case_ids(
        [{"kind": "sleep", "seconds": 0.3, "tags": [i]} for i in range(40)]), strict=True)]
    with pytest.raises(ValueError, match="another case under id"):
        run_batch(cases, out, engine="serial")
    original = [{"kind": "sleep", "seconds": 0.3, "tags": [i]} for i in range(40)]
    res = run_batch(original[:len(before) + 2], out, engine="serial")
    assert res.skipped == len(before) and res.ran == 2
    assert [r["wall_time_s"] for r in res.rows[:len(before)]] == [r["wall_time_s"] for r in before]


def test_failures_are_kept_unless_asked_to_run_again(tmp_path):
    out = tmp_path / "r.jsonl"
    cases = [{"kind": "sleep", "raise": "no"}, {"kind": "sleep"}]
    assert run_batch(cases, out, engine="serial").failed == 1
    again = run_batch(cases, out, engine="serial")
    assert (again.ran, again.skipped) == (0, 2)
    assert run_batch(cases, out, engine="serial", retry_failed=True).ran == 1


def test_cases_files_and_ids(tmp_path):
    p = write_cases(tmp_path / "c.jsonl", CASES)
    assert read_cases(p) == CASES
    y = tmp_path / "c.yml"
    y.write_text("- {kind: sleep, seconds: 0.1}\n- {kind: gait, robot: paper-5c, seconds: 1.5, reverse: true}\n")
    assert read_cases(y)[1]["reverse"] is True
    ids = case_ids([{"kind": "sleep"}, {"kind": "sleep"}, {"kind": "sleep", "id": "mine"}])
    assert ids[1] == ids[0] + "-2" and ids[2] == "mine"
    bad = tmp_path / "bad.jsonl"
    bad.write_text('{"kind": "sleep"}\n{"kind": "gait", "robto": "paper-5c"}\n')
    with pytest.raises(ValueError, match=r"bad.jsonl line 2: unknown key\(s\) \['robto'\]"):
        read_cases(bad)
    with pytest.raises(ValueError, match="'kind' must be one of"):
        read_cases([{"kind": "walk"}])


def test_chunks_group_millisecond_jobs_only(tmp_path):
    from magsoft_env.parallel.batch import _chunks

    pending = [(str(i), {"kind": "equilibrium"}) for i in range(100)] + [("g", {"kind": "gait"})]
    chunks = _chunks(pending, None, 2)
    assert chunks[0] == [("g", {"kind": "gait"})] and {len(c) for c in chunks[1:-1]} == {13}
    assert sum(len(c) for c in chunks) == 101


def test_generators_are_seeded_and_stay_in_their_ranges():
    base = {"kind": "gait", "robot": "paper-5c", "seconds": 1.5}
    g = sweeps.grid(base, {"scale.E0": [0.9, 1.1], "friction": [0.3, 0.5, 0.7]})
    assert len(g) == 6 and g[1] == {**base, "scale": {"E0": 0.9}, "friction": 0.5}
    h = sweeps.latin_hypercube(base, {"scale.thickness": (0.9, 1.1), "seconds": (1.0, 2.0)}, 10, seed=3)
    assert h == sweeps.latin_hypercube(base, {"scale.thickness": (0.9, 1.1), "seconds": (1.0, 2.0)}, 10, seed=3)
    t = sorted(c["scale"]["thickness"] for c in h)
    assert all(0.9 + 0.02 * i <= v < 0.9 + 0.02 * (i + 1) for i, v in enumerate(t))  # one per stratum
    m = sweeps.monte_carlo(base, 200, seed=1)
    assert m == sweeps.monte_carlo(base, 200, seed=1) and m != sweeps.monte_carlo(base, 200, seed=2)
    import numpy as np

    e0 = np.array([c["scale"]["E0"] for c in m])
    assert abs(e0.mean() - 1) < 0.03 and abs(e0.std() - 0.1) < 0.02
    with pytest.raises(ValueError, match="scatter keys"):
        sweeps.monte_carlo(base, 3, {"modulus": 0.1})


def test_summary_of_a_batch():
    rows = [{"id": str(i), "ok": True, "case": {"kind": "gait", "scale": {"E0": 1 + 0.1 * i}},
             "result": {"speed_mm_s": 2.0 + i}} for i in range(5)]
    rows.append({"id": "x", "ok": False, "case": {"kind": "gait"}, "error": {"type": "ValueError", "message": "m"}})
    s = sweeps.summarize(rows)
    assert (s["metric"], s["n"], s["ok"], s["failed"], s["median"]) == ("speed_mm_s", 5, 5, 1, 4.0)
    text = sweeps.summary_table(rows)
    assert "scale.E0" in text and "+1.000" in text and "failed x: ValueError: m" in text


def test_magsoft_batch_command(tmp_path, capsys):
    cases = tmp_path / "c.jsonl"
    write_cases(cases, [{"kind": "sleep", "seconds": 0.01}, {"kind": "sleep", "raise": "bad"}])
    code = main(["batch", str(cases), "--out", str(tmp_path / "r.jsonl"), "--engine", "serial"])
    out = capsys.readouterr().out
    assert code == 1 and "2 cases: 1 ok, 1 failed" in out and "failed" in out
    code = main(["batch", "--base", '{"kind": "sleep"}', "--grid", "seconds=0,0.01,0.02",
                 "--out", str(tmp_path / "g.jsonl"), "--engine", "serial", "--json",
                 "--plot", str(tmp_path / "g.png"), "--write-cases", str(tmp_path / "g_cases.jsonl")])
    summary = json.loads(capsys.readouterr().out)
    assert code == 0 and summary["n"] == 3 and summary["metric"] == "seconds"
    assert (tmp_path / "g.png").stat().st_size > 1000 and len(read_cases(tmp_path / "g_cases.jsonl")) == 3
    assert main(["batch", "--monte-carlo", "3", "--out", str(tmp_path / "m.jsonl")]) == 2
    assert "--monte-carlo needs --base" in capsys.readouterr().err
    assert main(["batch", str(cases), "--out", str(tmp_path / "x.jsonl"), "--address", "auto"]) == 2


def test_importing_the_package_or_running_the_local_engine_imports_no_ray(tmp_path):
    code = textwrap.dedent(f"""
        import sys
        import magsoft_env, magsoft_env.parallel, magsoft_env.cli.batch
        from magsoft_env.parallel import run_batch

        if __name__ == "__main__":
            assert "ray" not in sys.modules
            res = run_batch([{{"kind": "sleep"}}, {{"kind": "equilibrium", "robot": "paper-5c"}}],
                            {str(tmp_path / 'r.jsonl')!r}, engine="local", workers=2)
            assert res.ok == 2, res.rows
            assert not [m for m in sys.modules if m == "ray" or m.startswith("ray.")]
            print("no ray")
    """)
    script = tmp_path / "probe.py"
    script.write_text(code)
    out = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=120,
                         env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert out.returncode == 0 and "no ray" in out.stdout, out.stderr
