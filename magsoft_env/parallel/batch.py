"""A batch of cases run on an engine, its results streamed to a JSON Lines file by the driver alone.

:func:`run_batch` reads the cases (a list of dicts, or a ``.jsonl``/``.yml`` file), gives each an id (its own
``id``, else a hash of its content), skips those the results file already holds (resume), cuts the rest into
chunks (millisecond-scale kinds are grouped, second-scale ones run alone), and hands them to an engine:

``serial``
    In this process, one case after the other: the reference.
``local`` (default)
    A pool of worker processes on the local machine (no extra dependency). The driver watches each worker: a case
    that runs past ``timeout`` is stopped (its worker killed and replaced) and becomes a failure row; a worker
    that dies (killed, out of memory) is replaced and its case retried up to ``retries`` times.
``ray``
    A Ray cluster (:mod:`magsoft_env.parallel.ray_engine`, the ``ray`` extra): a private one on the local machine, or
    an existing one joined by address.

Each finished case is one line of the results file, appended and flushed at once, so an interrupted batch
loses nothing it finished; when the batch completes the file is rewritten in the order of the cases, so the
same cases give the same file (every field but ``wall_time_s``) whatever the engine, the number of workers or
the order in which cases finished. A row::

    {"index": 3, "id": "c5f0...", "ok": true, "case": {...}, "result": {...}, "wall_time_s": 0.41}
    {"index": 4, "id": "8a1b...", "ok": false, "case": {...}, "error": {"type": "ValueError", "message": ...}, ...}
"""

from __future__ import annotations

import collections
import dataclasses
import hashlib
import json
import math
import os
import sys
import time
from pathlib import Path

from ..io import jsonable, write_text_atomic
from .jobs import check_case, run_one, timeout_error

#: Engines :func:`run_batch` knows.
ENGINES = ("serial", "local", "ray")
#: Kinds whose cases take milliseconds: grouped into chunks so the cost per task does not dominate.
LIGHT_KINDS = ("equilibrium", "sleep")
#: Cases per chunk at most (light kinds).
MAX_CHUNK = 64
#: Modules the local workers' server imports before it forks them (each worker would import them on its first case).
PRELOAD = ("magsoft_env.parallel.jobs", "magsoft_env.theory", "magsoft_env.sim.gait")


# ------------------------------------------------------------------------------------------ cases
def read_cases(source) -> list[dict]:
    """The cases of ``source``: a list of dicts, or a file: JSON Lines (``.jsonl``, ``.json``: one object a line;
    blank lines and lines starting with ``#`` skipped) or YAML (``.yml``/``.yaml``: a list of mappings).

    Raises ValueError naming the line of a case that is not an object of a known kind with known keys."""
    if isinstance(source, (list, tuple)):
        return [check_case(dict(c), where=f"case {i + 1}") for i, c in enumerate(source)]
    path = Path(source)
    if not path.is_file():
        raise ValueError(f"cases file {str(path)!r} does not exist.")
    text = path.read_text(encoding="utf-8")
    if path.suffix.lower() in (".yml", ".yaml"):
        import yaml

        try:
            data = yaml.safe_load(text)
        except yaml.YAMLError as exc:
            raise ValueError(f"cases file {str(path)!r} is not valid YAML: {exc}") from None
        if not isinstance(data, list):
            raise ValueError(f"cases file {str(path)!r} must hold a YAML list of cases.")
        return [check_case(c, where=f"{path.name} case {i + 1}") for i, c in enumerate(data)]
    cases = []
    for n, line in enumerate(text.splitlines(), 1):
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        try:
            case = json.loads(line)
        except json.JSONDecodeError as exc:
            raise ValueError(f"{path.name} line {n} is not valid JSON: {exc.msg}.") from None
        cases.append(check_case(case, where=f"{path.name} line {n}"))
    return cases


def write_cases(path, cases) -> Path:
    """Write ``cases`` as JSON Lines (atomically); returns the path."""
    return write_text_atomic(path, "".join(json.dumps(jsonable(c), allow_nan=False) + "\n" for c in cases))


def case_id(case: dict) -> str:
    """The case's own ``id``, else a hash of its content (the same case always gets the same id)."""
    if case.get("id") is not None:
        return str(case["id"])
    text = json.dumps(jsonable(case), sort_keys=True, separators=(",", ":"), allow_nan=False)
    return "c" + hashlib.sha1(text.encode()).hexdigest()[:12]


def case_ids(cases) -> list[str]:
    """:func:`case_id` of each case; a repeated case gets ``-2``, ``-3``, ... after its id."""
    seen = collections.Counter()
    out = []
    for c in cases:
        cid = case_id(c)
        seen[cid] += 1
        out.append(cid if seen[cid] == 1 else f"{cid}-{seen[cid]}")
    return out


# ------------------------------------------------------------------------------------------ results file
def read_results(path) -> list[dict]:
    """The rows of a results file (a missing file: none); a last line cut short by an interruption is ignored."""
    path = Path(path)
    if not path.exists():
        return []
    rows = []
    lines = path.read_text(encoding="utf-8").splitlines(keepends=True)
    for n, line in enumerate(lines, 1):
        if not line.strip():
            continue
        try:
            rows.append(json.loads(line))
        except json.JSONDecodeError:
            if n == len(lines) and not line.endswith("\n"):
                break  # the row being written when the batch stopped
            raise ValueError(f"results file {str(path)!r} line {n} is not valid JSON.") from None
    return rows


def comparable(row: dict) -> dict:
    """``row`` without its wall time and traceback: what must not depend on the engine."""
    out = {k: v for k, v in row.items() if k != "wall_time_s"}
    if "error" in out:
        out["error"] = {k: v for k, v in out["error"].items() if k != "traceback"}
    return out


class _Writer:
    """Appends rows to the results file, one flushed line each; cuts off a half-written last line first."""

    def __init__(self, path: Path):
        self.path = path
        path.parent.mkdir(parents=True, exist_ok=True)
        if path.exists():
            data = path.read_bytes()
            if data and not data.endswith(b"\n"):
                with open(path, "r+b") as fh:
                    fh.truncate(data.rfind(b"\n") + 1)
        self.fh = open(path, "a", encoding="utf-8")  # noqa: SIM115  closed by close()

    def write(self, row: dict):
        self.fh.write(json.dumps(jsonable(row), allow_nan=False) + "\n")
        self.fh.flush()

    def close(self):
        self.fh.flush()
        os.fsync(self.fh.fileno())
        self.fh.close()


# ------------------------------------------------------------------------------------------ the batch
@dataclasses.dataclass
class BatchResult:
    """What a batch did: ``rows`` (one per case, in the order of the cases), how many ran now, were found in
    the results file (``skipped``), succeeded and failed, the engine and the wall time (s)."""

    path: Path
    rows: list
    ran: int
    skipped: int
    ok: int
    failed: int
    engine: str
    wall_time_s: float

    @property
    def complete(self) -> bool:
        return len(self.rows) == self.ran + self.skipped and all(r is not None for r in self.rows)


def run_batch(cases, out, *, engine: str = "local", workers: int | None = None, address: str | None = None,
              timeout: float | None = None, retries: int = 2, chunk_size: int | None = None,
              max_in_flight: int | None = None, retry_failed: bool = False, progress: bool = False,
              ray_options: dict | None = None) -> BatchResult:
    """Run ``cases`` (a list of dicts or a cases file, :func:`read_cases`) on ``engine`` and write the results to
    ``out`` (JSON Lines, :mod:`magsoft_env.parallel.batch`).

    Parameters
    ----------
    engine : {"serial", "local", "ray"} or an engine
        Where the cases run (see the module docstring); an engine object (:class:`LocalEngine`,
        :class:`~magsoft_env.parallel.ray_engine.RayEngine`, ...) is used as it is.
    workers : int, optional
        Worker processes (``local``; default: the local CPUs) or CPUs of a private Ray (``ray`` with
        ``address=None``).
    address : str, optional
        ``ray`` only: None starts a private Ray on the local machine (never an existing one); ``"auto"`` joins the
        cluster the local machine belongs to, ``"HOST:PORT"`` the one at that address
        (:class:`~magsoft_env.parallel.ray_engine.RayEngine`).
    timeout : float, optional
        Seconds a case may run; a case that runs longer becomes a failure row (``CaseTimeout``).
    retries : int
        Times a case is run again when its worker (or node) dies under it. A case that raises is not retried:
        its error is its result.
    chunk_size : int, optional
        Cases per task for the millisecond-scale kinds (:data:`LIGHT_KINDS`); default: enough chunks for four
        per worker, at most :data:`MAX_CHUNK` cases each. Other kinds run one case per task.
    max_in_flight : int, optional
        ``ray``: tasks submitted and not finished at most (default twice the cluster's CPUs); ``local`` has one
        task per worker.
    retry_failed : bool
        Run again the cases the results file holds as failures (default: a failure is a result, kept).
    progress : bool
        A progress bar on stderr.
    ray_options : dict, optional
        More arguments of :class:`~magsoft_env.parallel.ray_engine.RayEngine`.
    """
    if isinstance(engine, str) and engine not in ENGINES:
        raise ValueError(f"engine must be one of {list(ENGINES)} or an engine object, got {engine!r}.")
    if address is not None and engine != "ray":
        raise ValueError(f"address applies to engine 'ray', got engine {engine!r}.")
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int) or not 1 <= workers <= 4096):
        raise ValueError(f"workers must be an integer in [1, 4096], got {workers!r}.")
    if timeout is not None and not (isinstance(timeout, (int, float)) and math.isfinite(timeout) and timeout > 0):
        raise ValueError(f"timeout must be a number of seconds > 0, got {timeout!r}.")
    if isinstance(retries, bool) or not isinstance(retries, int) or not 0 <= retries <= 100:
        raise ValueError(f"retries must be an integer in [0, 100], got {retries!r}.")
    if chunk_size is not None and (isinstance(chunk_size, bool) or not isinstance(chunk_size, int)
                                   or chunk_size < 1):
        raise ValueError(f"chunk_size must be an integer >= 1, got {chunk_size!r}.")
    cases = read_cases(cases)
    out = Path(out)
    ids = case_ids(cases)
    index = {cid: i for i, cid in enumerate(ids)}
    rows: list = [None] * len(cases)
    for row in read_results(out):
        i = index.get(row.get("id"))
        if i is None:
            continue
        if row.get("case") != jsonable(cases[i]):
            raise ValueError(f"results file {str(out)!r} holds another case under id {row['id']!r}: write these "
                             f"cases to another file (or give them other ids).")
        if row.get("ok") or not retry_failed:
            rows[i] = row
    skipped = sum(r is not None for r in rows)
    pending = [(ids[i], cases[i]) for i in range(len(cases)) if rows[i] is None]
    n_workers = workers or os.cpu_count() or 1
    chunks = _chunks(pending, chunk_size, n_workers)
    t0 = time.perf_counter()
    bar = _bar(len(pending), progress)
    writer = _Writer(out)
    counts = {"ran": 0}

    def emit(row):
        i = index[row["id"]]
        full = {"index": i, "id": row["id"], "ok": row["ok"], "case": cases[i]}
        full.update({k: v for k, v in row.items() if k not in ("id", "ok")})
        full = jsonable(full)
        writer.write(full)
        rows[i] = full
        counts["ran"] += 1
        bar.update(1)

    try:
        if pending:
            _engine(engine, workers, address, ray_options).run(
                chunks, timeout=timeout, retries=retries, emit=emit, max_in_flight=max_in_flight)
    finally:
        writer.close()
        bar.close()
    if all(r is not None for r in rows):  # complete: the file in the order of the cases
        write_text_atomic(out, "".join(json.dumps(r, allow_nan=False) + "\n" for r in rows))
    done = [r for r in rows if r is not None]
    ok = sum(bool(r["ok"]) for r in done)
    return BatchResult(path=out, rows=rows, ran=counts["ran"], skipped=skipped, ok=ok, failed=len(done) - ok,
                       engine=engine if isinstance(engine, str) else type(engine).__name__,
                       wall_time_s=time.perf_counter() - t0)


def _chunks(pending, chunk_size, workers):
    light = [p for p in pending if p[1]["kind"] in LIGHT_KINDS]
    heavy = [p for p in pending if p[1]["kind"] not in LIGHT_KINDS]
    size = chunk_size or max(1, min(MAX_CHUNK, math.ceil(len(light) / (4 * workers))))
    out = [[p] for p in heavy]  # the long ones first: they set the batch's end
    out += [light[i:i + size] for i in range(0, len(light), size)]
    return out


def _bar(total, enabled):
    from tqdm import tqdm

    return tqdm(total=total, disable=not enabled, file=sys.stderr, unit="case", dynamic_ncols=True)


def _engine(name, workers, address, ray_options):
    if not isinstance(name, str):
        return name
    if name == "serial":
        return SerialEngine()
    if name == "local":
        return LocalEngine(workers)
    from .ray_engine import RayEngine

    return RayEngine(address=address, workers=workers, **(ray_options or {}))


class SerialEngine:
    """Every case in this process, one after the other (the per-case timeout by an alarm signal)."""

    def run(self, chunks, *, timeout, retries, emit, max_in_flight=None):
        for chunk in chunks:
            for cid, case in chunk:
                emit(run_one(cid, case, timeout=timeout))


# ------------------------------------------------------------------------------------------ the local pool
def _worker_main(conn):
    """A local worker: receives chunks, sends one row per case as each finishes; ``None`` ends it."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the driver's to handle
    while True:
        try:
            chunk = conn.recv()
        except EOFError:
            return
        if chunk is None:
            return
        for cid, case in chunk:
            conn.send(("start", cid))  # the case's clock starts now, not when the chunk was sent
            conn.send(("row", run_one(cid, case)))


class _Worker:
    def __init__(self, ctx):
        self.conn, child = ctx.Pipe()
        self.proc = ctx.Process(target=_worker_main, args=(child,), daemon=True, name="magsoft-batch-worker")
        self.proc.start()
        child.close()
        self.chunk, self.pos, self.deadline = None, 0, math.inf

    def assign(self, chunk, timeout):
        self.chunk, self.pos, self.deadline = chunk, 0, math.inf
        self.conn.send(chunk)

    def stop(self, kill=False):
        if kill:
            self.proc.kill()
        else:
            try:
                self.conn.send(None)
            except OSError:
                pass
        self.proc.join(timeout=5)
        if self.proc.is_alive():
            self.proc.kill()
            self.proc.join()
        self.conn.close()


class LocalEngine:
    """A pool of ``workers`` processes on the local machine (default: its CPUs), watched by the driver.

    Each worker takes one chunk at a time and sends each case's row back as it finishes, so the driver always
    knows which case is running: a case past ``timeout`` has its worker killed and replaced, and becomes a
    ``CaseTimeout`` failure row; a worker that dies has its running case retried (up to ``retries`` times, then
    a ``WorkerDied`` failure row) and the rest of its chunk handed out again. Workers start with the
    ``forkserver`` method where the platform has it (else ``spawn``), the server having imported :data:`PRELOAD`:
nothing of the driver's state is shared. As with any process pool, a script that runs a batch on this engine
must do so under ``if __name__ == "__main__":`` (the workers import the main module).
    """

    def __init__(self, workers: int | None = None):
        self.workers = workers or os.cpu_count() or 1
        self.pids: list[int] = []  # the workers' process ids while a batch runs

    def run(self, chunks, *, timeout, retries, emit, max_in_flight=None):
        import multiprocessing as mp
        from multiprocessing.connection import wait

        if "forkserver" in mp.get_all_start_methods():
            ctx = mp.get_context("forkserver")
            # imported once in the server, which forks the workers: they start with the solvers loaded
            ctx.set_forkserver_preload(list(PRELOAD))
        else:
            ctx = mp.get_context("spawn")
        queue = collections.deque(chunks)
        attempts = collections.Counter()
        pool = [_Worker(ctx) for _ in range(min(self.workers, len(queue)))]
        self.pids = [w.proc.pid for w in pool]
        try:
            while True:
                for k, w in enumerate(pool):
                    if queue and w is None:  # a replacement, started when there is work for it
                        pool[k] = w = _Worker(ctx)
                        self.pids = [x.proc.pid for x in pool if x is not None]
                    if w is not None and w.chunk is None and queue:
                        w.assign(queue.popleft(), timeout)
                active = [w for w in pool if w is not None and w.chunk is not None]
                if not active:
                    break
                left = min(w.deadline for w in active) - time.monotonic()
                ready = set(wait([w.conn for w in active] + [w.proc.sentinel for w in active],
                                 timeout=None if math.isinf(left) else max(0.0, left)))
                for k, w in enumerate(pool):
                    if w is None or w.chunk is None:
                        continue
                    died = False
                    if w.conn in ready or w.proc.sentinel in ready:
                        try:
                            while w.chunk is not None and w.conn.poll():
                                what, msg = w.conn.recv()
                                if what == "start":
                                    w.deadline = math.inf if timeout is None else time.monotonic() + timeout
                                    continue
                                emit(msg)
                                w.pos += 1
                                w.deadline = math.inf
                                if w.pos == len(w.chunk):
                                    w.chunk = None
                        except (EOFError, OSError):
                            died = True
                        died = died or (w.chunk is not None and not w.proc.is_alive() and not w.conn.poll())
                    if w.chunk is None:
                        continue
                    cid, case = w.chunk[w.pos]
                    if died:
                        code = w.proc.exitcode
                        attempts[cid] += 1
                        rest = w.chunk[w.pos:]
                        if attempts[cid] > retries:
                            emit({"id": cid, "ok": False, "wall_time_s": None,
                                  "error": {"type": "WorkerDied", "traceback": "",
                                            "message": f"the worker running the case died (exit code {code}) "
                                                       f"{attempts[cid]} times"}})
                            rest = rest[1:]
                    elif time.monotonic() >= w.deadline:
                        emit({"id": cid, "ok": False, "error": timeout_error(timeout), "wall_time_s": timeout})
                        rest = w.chunk[w.pos + 1:]
                    else:
                        continue
                    if rest:
                        queue.appendleft(rest)
                    w.chunk = None
                    w.stop(kill=True)
                    pool[k] = None
        finally:
            self.pids = []
            for w in pool:
                if w is not None:
                    w.stop(kill=w.chunk is not None)


__all__ = ["ENGINES", "LIGHT_KINDS", "MAX_CHUNK", "BatchResult", "LocalEngine", "SerialEngine", "case_id",
           "case_ids", "comparable", "read_cases", "read_results", "run_batch", "write_cases"]
