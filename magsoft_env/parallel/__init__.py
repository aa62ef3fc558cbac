"""Batches of cases (equilibria, paths, inverse designs, gaits, cross-checks, rollouts) on one machine or a cluster.

Cases are data (:mod:`magsoft_env.parallel.jobs`), results a JSON Lines file the driver writes
(:mod:`magsoft_env.parallel.batch`), engines ``serial``, ``local`` (a process pool, the default) and ``ray``
(:mod:`magsoft_env.parallel.ray_engine`, the ``ray`` extra), generators of sweeps and Monte-Carlo scatter and a
summary of the results (:mod:`magsoft_env.parallel.sweeps`). Importing this package imports no Ray.

>>> from magsoft_env.parallel import run_batch
>>> cases = [{"kind": "equilibrium", "robot": "paper-5c", "field_mT": [0.0, 5.0]}]
>>> run_batch(cases, "results.jsonl").ok  # doctest: +SKIP
1
"""

from __future__ import annotations

from .batch import (
    ENGINES,
    BatchResult,
    LocalEngine,
    SerialEngine,
    case_id,
    case_ids,
    comparable,
    read_cases,
    read_results,
    run_batch,
    write_cases,
)
from .jobs import KINDS, SCALE_KEYS, check_case, run_case, run_one

__all__ = ["ENGINES", "KINDS", "SCALE_KEYS", "BatchResult", "LocalEngine", "SerialEngine", "case_id", "case_ids",
           "check_case", "comparable", "read_cases", "read_results", "run_batch", "run_case", "run_one",
           "write_cases"]
