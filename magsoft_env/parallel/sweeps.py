"""Generators of the common batches, and a summary of their results.

A generator takes a base case (any kind, :mod:`magsoft_env.parallel.jobs`) and returns cases that differ from it
in the keys it varies, named by a dotted path: ``scale.E0`` (a factor on the robot's modulus), ``seconds``,
``field_mT.1`` (the second component), ``friction``:

- :func:`grid`: every combination of the given values;
- :func:`latin_hypercube`: ``n`` cases spread over the given ranges (a seeded Latin hypercube);
- :func:`monte_carlo`: ``n`` cases whose robot scatters around the base one, each ``scale`` factor drawn from a
  normal distribution of the given relative standard deviation (manufacturing scatter of the modulus, the
  magnetization, the thickness), seeded.

:func:`summarize` gives the distribution of one result (the crawl speed of gaits, the tip deflection of
equilibria, the shape error of designs) over the successful rows, :func:`summary_table` prints it with the
correlation of the result with each varied input, :func:`plot_summary` draws a histogram and the result against
each varied input.
"""

from __future__ import annotations

import copy
import itertools
import math

import numpy as np

from .jobs import SCALE_KEYS, check_case

#: Relative standard deviations of the default Monte-Carlo scatter: modulus 10 %, magnetization 5 %, thickness 5 %.
DEFAULT_SCATTER = {"E0": 0.10, "magnetization": 0.05, "thickness": 0.05}
#: The result summarized by default, per kind.
DEFAULT_METRIC = {"gait": "speed_mm_s", "equilibrium": "v_over_L", "design": "rms_error_percent_L",
                  "rollout": "speed_mm_s", "sleep": "seconds"}


def set_key(case: dict, key: str, value) -> dict:
    """A copy of ``case`` with the dotted ``key`` set (``scale.E0``, ``field_mT.1``); missing objects are created."""
    out = copy.deepcopy(case)
    parts = key.split(".")
    node = out
    for p in parts[:-1]:
        if isinstance(node, list):
            node = node[int(p)]
        else:
            node = node.setdefault(p, {})
    last = parts[-1]
    if isinstance(node, list):
        node[int(last)] = value
    else:
        node[last] = value
    return out


def get_key(obj, key: str):
    """The value at the dotted ``key`` of ``obj`` (None where missing)."""
    for p in key.split("."):
        if isinstance(obj, list):
            try:
                obj = obj[int(p)]
            except (ValueError, IndexError):
                return None
        elif isinstance(obj, dict):
            obj = obj.get(p)
        else:
            return None
    return obj


def _base(base) -> dict:
    return check_case(copy.deepcopy(dict(base)), where="base case")


def grid(base: dict, axes: dict) -> list[dict]:
    """Every combination of ``axes`` (dotted key -> list of values), the last key varying fastest."""
    base = _base(base)
    if not axes:
        raise ValueError("a grid needs at least one axis (KEY=V1,V2,...).")
    keys = list(axes)
    out = []
    for values in itertools.product(*(list(axes[k]) for k in keys)):
        case = base
        for k, v in zip(keys, values, strict=True):
            case = set_key(case, k, v)
        out.append(check_case(case))
    return out


def latin_hypercube(base: dict, ranges: dict, n: int, *, seed: int = 0) -> list[dict]:
    """``n`` cases over ``ranges`` (dotted key -> (low, high)), a Latin hypercube drawn with ``seed``."""
    from scipy.stats import qmc

    base = _base(base)
    _count(n)
    if not ranges:
        raise ValueError("a Latin hypercube needs at least one range (KEY=LOW:HIGH).")
    lo = np.array([float(r[0]) for r in ranges.values()])
    hi = np.array([float(r[1]) for r in ranges.values()])
    if not np.all(hi > lo):
        raise ValueError(f"every range needs low < high, got {dict(ranges)}.")
    pts = qmc.scale(qmc.LatinHypercube(d=len(ranges), seed=seed).random(n), lo, hi)
    out = []
    for i, row in enumerate(pts):
        case = base
        for k, v in zip(ranges, row, strict=True):
            case = set_key(case, k, float(v))
        out.append(check_case({**case, "sample": i}))
    return out


def monte_carlo(base: dict, n: int, scatter: dict | None = None, *, seed: int = 0) -> list[dict]:
    """``n`` cases whose robot scatters around the base case's: each factor ``scale.K`` is ``1 + s z`` with ``s``
    the relative standard deviation ``scatter[K]`` (default :data:`DEFAULT_SCATTER`) and ``z`` a standard normal
    draw clipped to [-3, 3], from a generator seeded with ``seed``. Each case also records its ``sample`` number."""
    base = _base(base)
    _count(n)
    scatter = dict(DEFAULT_SCATTER if scatter is None else scatter)
    unknown = sorted(set(scatter) - set(SCALE_KEYS))
    if unknown:
        raise ValueError(f"scatter keys must be among {list(SCALE_KEYS)}, got {unknown}.")
    for k, s in scatter.items():
        if not (isinstance(s, (int, float)) and 0 <= s < 1 / 3):
            raise ValueError(f"scatter {k} must be a relative standard deviation in [0, 1/3), got {s!r}.")
    rng = np.random.default_rng(seed)
    z = np.clip(rng.standard_normal((n, len(scatter))), -3.0, 3.0)
    out = []
    for i in range(n):
        case = base
        for j, (k, s) in enumerate(scatter.items()):
            own = get_key(base, f"scale.{k}") or 1.0  # a factor the base case already has: scatter around it
            case = set_key(case, f"scale.{k}", float(own * (1.0 + s * z[i, j])))
        out.append(check_case({**case, "sample": i}))
    return out


def _count(n):
    if isinstance(n, bool) or not isinstance(n, int) or not 1 <= n <= 10_000_000:
        raise ValueError(f"the number of cases must be an integer in [1, 10000000], got {n!r}.")


# ------------------------------------------------------------------------------------------ summary
def default_metric(rows) -> str | None:
    """The result summarized by default for ``rows`` (their first case's kind); None if there is none."""
    for r in rows:
        if r is not None:
            return DEFAULT_METRIC.get(r["case"]["kind"])
    return None


def varied_keys(rows) -> list[str]:
    """Dotted keys of the numeric case values that differ between the rows (``scale.E0``, ``seconds``, ...)."""
    flat = [dict(_flatten(r["case"])) for r in rows if r is not None and r["ok"]]
    keys = sorted({k for f in flat for k in f})
    out = []
    for k in keys:
        vals = {f.get(k, 1.0 if k.startswith("scale.") else None) for f in flat}  # a missing factor is 1
        if len(vals) > 1 and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in vals) \
                and k not in ("sample", "seed"):
            out.append(k)
    return out


def _flatten(obj, prefix=""):
    if isinstance(obj, dict):
        for k, v in obj.items():
            yield from _flatten(v, f"{prefix}{k}.")
    elif isinstance(obj, list):
        for i, v in enumerate(obj):
            yield from _flatten(v, f"{prefix}{i}.")
    else:
        yield prefix[:-1], obj


def summarize(rows, metric: str | None = None) -> dict:
    """The distribution of ``metric`` (a dotted key of the results) over the successful rows: ``n``, ``mean``,
    ``std``, ``min``, ``p5``, ``median``, ``p95``, ``max``; and the counts of rows ``ok`` and ``failed``
    (``missing``: ok rows without a number there, such as a tumble's speed)."""
    rows = [r for r in rows if r is not None]
    metric = metric or default_metric(rows)
    ok = [r for r in rows if r["ok"]]
    vals = np.array([v for r in ok if isinstance(v := get_key(r["result"], metric or ""), (int, float))
                     and not isinstance(v, bool) and math.isfinite(v)], dtype=float)
    out = {"metric": metric, "cases": len(rows), "ok": len(ok), "failed": len(rows) - len(ok),
           "missing": len(ok) - len(vals), "n": len(vals)}
    if len(vals):
        q = np.percentile(vals, [5, 50, 95])
        out.update(mean=float(vals.mean()), std=float(vals.std(ddof=1)) if len(vals) > 1 else 0.0,
                   min=float(vals.min()), p5=float(q[0]), median=float(q[1]), p95=float(q[2]), max=float(vals.max()))
    return out


def _pairs(rows, metric, key):
    xs, ys = [], []
    for r in rows:
        if r is None or not r["ok"]:
            continue
        x, y = get_key(r["case"], key), get_key(r["result"], metric)
        x = 1.0 if x is None and key.startswith("scale.") else x
        if isinstance(x, (int, float)) and isinstance(y, (int, float)) and math.isfinite(y):
            xs.append(float(x))
            ys.append(float(y))
    return np.array(xs), np.array(ys)


def summary_table(rows, metric: str | None = None) -> str:
    """The summary as text: counts, the distribution of ``metric``, its correlation with each varied input, and
    the first failures."""
    from ..io import format_table

    s = summarize(rows, metric)
    lines = [f"{s['cases']} cases: {s['ok']} ok, {s['failed']} failed"
             + (f", {s['missing']} ok without {s['metric']}" if s["missing"] else "")]
    if s["n"]:
        cols = [(k, k, ".4g") for k in ("mean", "std", "min", "p5", "median", "p95", "max")]
        lines.append(f"{s['metric']} over {s['n']} cases:")
        lines.append(format_table([s], [("n", "n", "d"), *cols]))
        corr = []
        for k in varied_keys(rows):
            x, y = _pairs(rows, s["metric"], k)
            if len(x) > 2 and np.ptp(x) > 0 and np.ptp(y) > 0:
                corr.append({"input": k, "low": float(x.min()), "high": float(x.max()),
                             "r": float(np.corrcoef(x, y)[0, 1])})
        if corr:
            lines.append(f"correlation of {s['metric']} with each varied input:")
            lines.append(format_table(corr, [("input", "input", ""), ("low", "low", ".4g"), ("high", "high", ".4g"),
                                             ("r", "r", "+.3f")]))
    failed = [r for r in rows if r is not None and not r["ok"]]
    for r in failed[:5]:
        lines.append(f"failed {r['id']}: {r['error']['type']}: {r['error']['message'][:200]}")
    if len(failed) > 5:
        lines.append(f"... and {len(failed) - 5} more failures (see the results file)")
    return "\n".join(lines)


def plot_summary(rows, path, metric: str | None = None):
    """A PNG: the histogram of ``metric`` and the metric against each varied input (at most three); returns the
    path, or None when no successful row has the metric."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ..io import atomic_path

    s = summarize(rows, metric)
    if not s["n"]:
        return None
    metric = s["metric"]
    vals = np.array([get_key(r["result"], metric) for r in rows if r is not None and r["ok"]
                     and isinstance(get_key(r["result"], metric), (int, float))], dtype=float)
    keys = varied_keys(rows)[:3]
    fig, axes = plt.subplots(1, 1 + len(keys), figsize=(4.2 * (1 + len(keys)), 3.4), squeeze=False)
    ax = axes[0, 0]
    ax.hist(vals[np.isfinite(vals)], bins=max(5, min(40, int(np.sqrt(len(vals))) + 1)), color="tab:blue")
    ax.set_xlabel(metric)
    ax.set_ylabel("cases")
    ax.set_title(f"{s['n']} cases: median {s['median']:.3g}, 5-95 % [{s['p5']:.3g}, {s['p95']:.3g}]", fontsize=9)
    for ax, k in zip(axes[0, 1:], keys, strict=True):
        x, y = _pairs(rows, metric, k)
        ax.plot(x, y, ".", color="tab:orange")
        ax.set_xlabel(k)
        ax.set_ylabel(metric)
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    plt.close(fig)
    return path


__all__ = ["DEFAULT_METRIC", "DEFAULT_SCATTER", "default_metric", "get_key", "grid", "latin_hypercube", "monte_carlo",
           "plot_summary", "set_key", "summarize", "summary_table", "varied_keys"]
