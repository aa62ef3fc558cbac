"""``magsoft batch``: run a file of cases (one job a line) on a process pool or a Ray cluster, or generate a sweep
or a Monte-Carlo scatter around one case and run it; print a summary table, draw a plot."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from .output import dumps_json, out_file


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "batch",
        help="run many cases (equilibria, designs, gaits, ...) on a process pool or a Ray cluster; sweeps and "
             "Monte-Carlo scatter",
        description=(
            "Run the cases of CASES (JSON Lines: one object a line, such as {\"kind\": \"gait\", \"robot\": "
            "\"paper-5c\", \"seconds\": 1.5}; or a YAML list) and write one JSON line per case to --out, with its "
            "result or its error. A results file that already holds cases is resumed: finished cases are skipped. "
            "Instead of CASES, --base CASE with --grid, --lhs or --monte-carlo generates the cases. Kinds: "
            "equilibrium, path, gait, design, crosscheck, rollout, sleep (docs/parallel.md). Exit status 1 when a "
            "case failed."),
    )
    p.add_argument("cases", nargs="?", type=Path, default=None, metavar="CASES",
                   help="cases file (.jsonl or .yml)")
    p.add_argument("--out", type=Path, default=None, metavar="RESULTS",
                   help="results file (JSON Lines; resumed if it exists)")
    run = p.add_argument_group("engine")
    run.add_argument("--engine", choices=("serial", "local", "ray"), default="local",
                     help="serial (this process), local (a process pool, default) or ray")
    run.add_argument("--address", default=None,
                     help="ray: 'auto' or HOST:PORT of a running cluster (default: a private Ray on the local machine)")
    run.add_argument("--workers", type=int, default=None,
                     help="worker processes (local) or CPUs of the private Ray (default: the local CPUs)")
    run.add_argument("--timeout", type=float, default=None, metavar="S",
                     help="seconds a case may run before it becomes a failure row (default: no limit)")
    run.add_argument("--retries", type=int, default=2,
                     help="runs again of a case whose worker or node died (default 2)")
    run.add_argument("--chunk", type=int, default=None,
                     help="cases per task for equilibria (default: four chunks per worker, at most 64 cases)")
    run.add_argument("--retry-failed", action="store_true", help="run again the failure rows of the results file")
    run.add_argument("--ray-token-file", default=None, metavar="PATH",
                     help="ray: the cluster's token, if not in ~/.ray/auth_token")
    run.add_argument("--node-ip-address", default=None,
                     help="ray: the driver's address in the cluster (default: the --address host if loopback)")
    gen = p.add_argument_group("generated cases")
    gen.add_argument("--base", default=None, metavar="CASE",
                     help="the case to vary: a JSON object, or a file holding one")
    gen.add_argument("--grid", action="append", default=[], metavar="KEY=V1,V2,...",
                     help="a grid axis (repeatable), KEY a dotted path: scale.E0=0.9,1,1.1")
    gen.add_argument("--lhs", type=int, default=None, metavar="N", help="N cases over the --range boxes")
    gen.add_argument("--range", action="append", default=[], metavar="KEY=LOW:HIGH",
                     help="a Latin-hypercube range (repeatable): scale.thickness=0.9:1.1")
    gen.add_argument("--monte-carlo", type=int, default=None, metavar="N",
                     help="N cases scattered around the base robot (default scatter: E0 10 %%, magnetization 5 %%, "
                          "thickness 5 %%)")
    gen.add_argument("--scatter", action="append", default=[], metavar="KEY=SD",
                     help="relative standard deviation of a scale factor (repeatable): E0=0.1")
    gen.add_argument("--seed", type=int, default=0, help="seed of --lhs and --monte-carlo (default 0)")
    gen.add_argument("--write-cases", type=Path, default=None, metavar="PATH",
                     help="write the generated cases to PATH (JSON Lines); without --out, run nothing")
    rep = p.add_argument_group("report")
    rep.add_argument("--metric", default=None,
                     help="result to summarize (default per kind: speed_mm_s, v_over_L, rms_error_percent_L)")
    rep.add_argument("--plot", type=Path, default=None, metavar="PNG",
                     help="histogram of the metric and the metric against each varied input")
    rep.add_argument("--json", action="store_true", help="print the summary as one JSON object")
    rep.add_argument("--progress", action=argparse.BooleanOptionalAction, default=None,
                     help="progress bar on stderr (default: when stderr is a terminal)")
    p.set_defaults(run=run_batch_command)
    return p


def _pairs(items, flag, parse):
    out = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key:
            raise ValueError(f"{flag} takes KEY=VALUE, got {item!r}.")
        try:
            out[key] = parse(value)
        except ValueError:
            raise ValueError(f"{flag} {item!r}: cannot read {value!r}.") from None
    return out


def _numbers(text):
    return [json.loads(v) for v in text.split(",") if v.strip()]


def _interval(text):
    lo, sep, hi = text.partition(":")
    if not sep:
        raise ValueError(text)
    return float(lo), float(hi)


def _base(text):
    path = Path(text)
    raw = path.read_text(encoding="utf-8") if not text.lstrip().startswith("{") and path.is_file() else text
    try:
        base = json.loads(raw)
    except json.JSONDecodeError as exc:
        raise ValueError(f"--base must be a JSON object or a file holding one: {exc.msg}.") from None
    if not isinstance(base, dict):
        raise ValueError(f"--base must be a JSON object, got {type(base).__name__}.")
    return base


def generated_cases(args):
    """The cases --base with --grid, --lhs or --monte-carlo make; None when none of them is given."""
    from magsoft_env.parallel import sweeps

    modes = [m for m, on in (("--grid", args.grid), ("--lhs", args.lhs is not None),
                             ("--monte-carlo", args.monte_carlo is not None)) if on]
    if not modes:
        if args.base or args.range or args.scatter:
            raise ValueError("--base, --range and --scatter go with --grid, --lhs or --monte-carlo.")
        return None
    if len(modes) > 1:
        raise ValueError(f"give one of --grid, --lhs, --monte-carlo, got {modes}.")
    if args.base is None:
        raise ValueError(f"{modes[0]} needs --base CASE, the case to vary.")
    if args.cases is not None:
        raise ValueError(f"give CASES or --base with {modes[0]}, not both.")
    base = _base(args.base)
    if args.grid:
        return sweeps.grid(base, _pairs(args.grid, "--grid", _numbers))
    if args.lhs is not None:
        return sweeps.latin_hypercube(base, _pairs(args.range, "--range", _interval), args.lhs, seed=args.seed)
    scatter = _pairs(args.scatter, "--scatter", float) or None
    return sweeps.monte_carlo(base, args.monte_carlo, scatter, seed=args.seed)


def run_batch_command(args) -> int:
    from magsoft_env.parallel import read_cases, run_batch, write_cases
    from magsoft_env.parallel.sweeps import summarize, summary_table

    if args.workers is not None and not 1 <= args.workers <= 4096:
        raise ValueError(f"--workers must be an integer in [1, 4096], got {args.workers}.")
    if args.engine != "ray" and (args.address or args.ray_token_file or args.node_ip_address):
        raise ValueError("--address, --ray-token-file and --node-ip-address apply to --engine ray.")
    cases = generated_cases(args)
    if cases is None:
        if args.cases is None:
            raise ValueError("give CASES (a cases file) or --base with --grid, --lhs or --monte-carlo.")
        cases = read_cases(args.cases)
    if args.out is None and args.write_cases is None:
        raise ValueError("give --out RESULTS (or --write-cases PATH to only write the generated cases).")
    if args.out is not None:
        args.out = out_file(args.out)
    if args.plot is not None:
        args.plot = out_file(args.plot, flag="--plot", suffixes=(".png",))
    if args.write_cases is not None:
        write_cases(out_file(args.write_cases, flag="--write-cases"), cases)
        print(f"wrote {len(cases)} cases to {args.write_cases}", file=sys.stderr if args.json else sys.stdout)
    if args.out is None:
        return 0
    ray_options = {k: v for k, v in (("auth_token_file", args.ray_token_file),
                                     ("node_ip_address", args.node_ip_address)) if v is not None}
    progress = sys.stderr.isatty() if args.progress is None else args.progress
    res = run_batch(cases, args.out, engine=args.engine, workers=args.workers, address=args.address,
                    timeout=args.timeout, retries=args.retries, chunk_size=args.chunk,
                    retry_failed=args.retry_failed, progress=progress, ray_options=ray_options or None)
    plot = None
    if args.plot is not None:
        from magsoft_env.parallel.sweeps import plot_summary

        plot = plot_summary(res.rows, args.plot, args.metric)
    if args.json:
        print(dumps_json({"results": str(res.path), "engine": res.engine, "ran": res.ran, "skipped": res.skipped,
                          "wall_time_s": res.wall_time_s, "plot": None if plot is None else str(plot),
                          **summarize(res.rows, args.metric)}))
    else:
        print(f"{res.ran} cases run on {res.engine} in {res.wall_time_s:.1f} s, {res.skipped} already in "
              f"{res.path}")
        print(summary_table(res.rows, args.metric))
        print(f"wrote {res.path}")
        if plot is not None:
            print(f"wrote {plot}")
        elif args.plot is not None:
            print("no plot: no successful case has the metric")
    return 1 if res.failed else 0
