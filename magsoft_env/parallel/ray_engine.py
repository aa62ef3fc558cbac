"""The Ray engine of :func:`~magsoft_env.parallel.run_batch` (the ``ray`` extra: ``pip install magsoft_env[ray]``).

Ray is imported when a batch starts on this engine, never before. What Ray 2.60 does that a user would trip
over, and what this engine does about it:

- A bare ``ray.init()`` attaches to any cluster recorded under the temp dir, even a dead one: ``address=None``
  starts a private Ray (``address="local"``) that ends with the batch; ``"auto"`` and ``"HOST:PORT"`` join.
- Token authentication is on by default: a process joining a cluster by address must run with
  ``RAY_AUTH_MODE=token`` and have the token (``~/.ray/auth_token``, ``RAY_AUTH_TOKEN_PATH`` or
  ``RAY_AUTH_TOKEN``). Joining, the engine sets ``RAY_AUTH_MODE=token`` when a token is there and the mode is not
  set, and ``auth_token_file`` points it at another file; without a token it says what to do.
- A node's loopback address is rewritten to the machine's routable one unless given: the private Ray binds
  127.0.0.1, and joining a cluster at a loopback address (``127.0.0.2:6379``) the driver takes that address as
  its own node's (``node_ip_address`` overrides).
- The object store takes 30 % of the RAM by default: the private Ray gets ``object_store_mb`` (256 MiB; results
  are small).
- Ray workers run with ``OMP_NUM_THREADS=1``: every engine runs its jobs with BLAS on one thread, so results do not
  depend on the engine.

A task is a chunk of cases (:func:`magsoft_env.parallel.jobs.run_chunk`); a worker or node that dies under it is
retried by Ray (``max_retries=retries``); a case past the timeout is interrupted in its worker (an alarm signal)
and, should that not reach it, the task is cancelled and its cases run again one per task, so the case at fault
is the one that fails.
"""

from __future__ import annotations

import logging
import math
import os
import time
from pathlib import Path

from .jobs import run_chunk, timeout_error

#: Object store of the private Ray (MiB): results are small; Ray's default is 30 % of the RAM.
OBJECT_STORE_MB = 256
#: Extra seconds before a task past its timeout is cancelled from the driver (the alarm in the worker comes first).
CANCEL_GRACE_S = 30.0


def _token_available() -> bool:
    if os.environ.get("RAY_AUTH_TOKEN"):
        return True
    path = os.environ.get("RAY_AUTH_TOKEN_PATH")
    return Path(path).is_file() if path else (Path.home() / ".ray" / "auth_token").is_file()


def _reread_auth_settings():
    """Ray reads the authentication mode and token once per process, maybe before they were set here."""
    try:
        from ray._raylet import AuthenticationTokenLoader, Config

        Config.initialize("")
        AuthenticationTokenLoader.instance().reset_cache()
    except (ImportError, AttributeError):  # another Ray: nothing cached this way
        pass


class RayEngine:
    """Run chunks of cases as Ray tasks.

    Parameters
    ----------
    address : str, optional
        None: a private Ray on the local machine with ``workers`` CPUs, started for the batch and shut down after
        it. ``"auto"``: the cluster the local machine is part of (``RAY_ADDRESS``, or the one ``ray start`` recorded);
        ``"HOST:PORT"``: the cluster whose head is there (the address ``ray start --head`` prints).
    workers : int, optional
        CPUs of the private Ray (default: the local machine's).
    node_ip_address : str, optional
        The driver's address in the cluster (default: the address's host when it is a loopback one).
    auth_token_file : str, optional
        The cluster's token (token authentication), if not in ``~/.ray/auth_token``.
    object_store_mb : int
        Object store of the private Ray (MiB).
    runtime_env : dict, optional
        Passed to ``ray.init`` (for example ``{"env_vars": {...}}``); the package must be installed on every node.
    """

    def __init__(self, address: str | None = None, workers: int | None = None, *, node_ip_address: str | None = None,
                 auth_token_file: str | None = None, object_store_mb: int = OBJECT_STORE_MB,
                 runtime_env: dict | None = None):
        if address is not None and (not isinstance(address, str) or not address
                                    or (address != "auto" and ":" not in address)):
            raise ValueError(f"address must be 'auto' or HOST:PORT (a Ray head), or None for a private Ray, "
                             f"got {address!r}.")
        if address == "local":
            address = None
        self.address, self.workers = address, workers
        self.node_ip_address, self.auth_token_file = node_ip_address, auth_token_file
        self.object_store_mb, self.runtime_env = object_store_mb, runtime_env
        self.owned = False
        self._saved_env: dict = {}

    def start(self):
        """Connect (or start the private Ray); returns the ``ray`` module."""
        try:
            import ray
        except ImportError:
            raise ValueError("engine 'ray' needs Ray: pip install 'magsoft_env[ray]' (or 'ray==2.60.*').") from None
        if ray.is_initialized():  # the caller's own session: use it, leave it running
            return ray
        kw = {"include_dashboard": False, "log_to_driver": False, "configure_logging": False}
        if self.runtime_env:
            kw["runtime_env"] = self.runtime_env
        if self.address is None:
            kw.update(address="local", num_cpus=self.workers or os.cpu_count() or 1,
                      object_store_memory=int(self.object_store_mb) * 2**20,
                      _node_ip_address=self.node_ip_address or "127.0.0.1")
        else:
            if self.auth_token_file is not None:
                if not Path(self.auth_token_file).is_file():
                    raise ValueError(f"auth token file {self.auth_token_file!r} does not exist.")
                self._setenv("RAY_AUTH_TOKEN_PATH", str(Path(self.auth_token_file).resolve()))
            if "RAY_AUTH_MODE" not in os.environ and _token_available():
                self._setenv("RAY_AUTH_MODE", "token")  # 2.60: a joining process needs the mode, not just the token
            _reread_auth_settings()
            kw["address"] = self.address
            host = self.address.rsplit(":", 1)[0]
            ip = self.node_ip_address or (host if host.startswith("127.") else None)
            if ip:
                kw["_node_ip_address"] = ip
        if self.address is None:  # "token authentication is enabled": true, and nothing for the user to do
            logging.getLogger("ray._private.authentication.authentication_token_setup").setLevel(logging.ERROR)
        try:
            ray.init(**kw)
        except ConnectionError as exc:
            hint = "" if _token_available() else (" No Ray token found: copy the cluster's ~/.ray/auth_token here or "
                                                  "give auth_token_file (--ray-token-file).")
            self._restore_env()
            raise ValueError(f"cannot join the Ray cluster at {self.address!r}: {exc}.{hint}") from None
        self.owned = True
        return ray

    def stop(self):
        if self.owned:
            import ray

            ray.shutdown()
            self.owned = False
        self._restore_env()

    def _setenv(self, key, value):
        self._saved_env.setdefault(key, os.environ.get(key))
        os.environ[key] = value

    def _restore_env(self):
        """The environment variables set for joining, as they were (they are read by ``ray.init`` only)."""
        for key, value in self._saved_env.items():
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value
        self._saved_env = {}

    def run(self, chunks, *, timeout, retries, emit, max_in_flight=None):
        ray = self.start()
        try:
            self._run(ray, list(chunks), timeout, retries, emit, max_in_flight)
        finally:
            self.stop()

    def _run(self, ray, chunks, timeout, retries, emit, max_in_flight):
        from ray.exceptions import RayError

        task = ray.remote(num_cpus=1, max_retries=retries, retry_exceptions=False)(run_chunk)
        cpus = int(ray.cluster_resources().get("CPU", 1))
        limit = max_in_flight or 2 * max(1, cpus)
        queue = list(reversed(chunks))
        flying = {}  # ref -> (chunk, cancel deadline)
        while queue or flying:
            while queue and len(flying) < limit:
                chunk = queue.pop()
                # queued behind at most one task per CPU: its cases' time twice, plus a grace
                grace = math.inf if timeout is None else 2 * timeout * len(chunk) + CANCEL_GRACE_S
                flying[task.remote(chunk, timeout)] = (chunk, time.monotonic() + grace)
            left = min(d for _, d in flying.values()) - time.monotonic()
            done, _ = ray.wait(list(flying), num_returns=1, timeout=None if math.isinf(left) else max(0.0, left))
            for ref in done:
                chunk, _ = flying.pop(ref)
                try:
                    rows = ray.get(ref)
                except RayError as exc:  # the worker or node died more than ``retries`` times, or cannot run jobs
                    cause = type(getattr(exc, "cause", None) or exc).__name__
                    lines = [ln for ln in str(exc).splitlines() if ln.strip()]
                    for cid, _case in chunk:
                        emit({"id": cid, "ok": False, "wall_time_s": None,
                              "error": {"type": cause, "message": (lines[-1] if lines else cause)[:500],
                                        "traceback": str(exc)[-4000:]}})
                    continue
                for row in rows:
                    emit(row)
            now = time.monotonic()
            for ref in [r for r, (_, d) in flying.items() if d <= now]:
                chunk, _ = flying.pop(ref)
                ray.cancel(ref, force=True)
                if len(chunk) > 1:  # find the case at fault: one task each
                    queue.extend([c] for c in reversed(chunk))
                else:
                    emit({"id": chunk[0][0], "ok": False, "error": timeout_error(timeout), "wall_time_s": timeout})


__all__ = ["CANCEL_GRACE_S", "OBJECT_STORE_MB", "RayEngine"]
