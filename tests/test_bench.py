"""The benchmark scripts still run (their short modes) and print the tables the docs quote.

Benchmarks are not pass/fail on their numbers (timings never are); these smoke runs catch a
script broken by an API change, and check the invariants of their outputs that do not depend on
the machine."""

import pytest

pytestmark = pytest.mark.slow


def _rows(text: str, prefix: str) -> list[str]:
    return [line for line in text.splitlines() if line.startswith(prefix)]


def test_sim_bench_convergence_quick(capsys):
    from magsoft_env.bench import sim_bench

    assert sim_bench.main(["--quick", "--only", "convergence"]) == 0
    rows = _rows(capsys.readouterr().out, (" A:", " 5c:"))
    assert len(rows) == 4  # two settings x two crawlers in --quick
    for row in rows:  # ref, pen, then crawl, error, pen at 1 and 0.5 ms: the last 8 columns
        ref, pen, c1, d1, p1, c5, d5, p5 = (float(v) for v in row.split()[-8:])
        assert ref * c1 > 0 and ref * c5 > 0  # same direction as the fine reference
        rounding = 100 * 5e-4 * (1 / abs(ref) + abs(c1) / ref**2) + 0.05  # the mm are printed to 3 decimals
        assert d1 == pytest.approx(100 * (c1 - ref) / ref, abs=rounding)
        assert min(pen, p1, p5) >= 0


def test_gait_sweep_quick_directions(capsys):
    from magsoft_env.bench import gait_sweep

    assert gait_sweep.main(["--quick", "--seconds", "1.0"]) == 0
    rows = _rows(capsys.readouterr().out, "| presets |")
    assert len(rows) == 4
    speeds = {r.split("|")[2].strip(): float(r.split("|")[7]) for r in rows}
    assert speeds["paper-5c"] < 0 < speeds["paper-5c --reverse"]  # the reversal, as docs/envs.md


def test_env_bench_short(capsys):
    from magsoft_env.bench import env_bench

    assert env_bench.main(["--steps", "10"]) in (0, None)
    out = capsys.readouterr().out
    for env_id in ("MagSoftCrawl-v1", "MagSoftShape-v0"):
        (row,) = [line for line in out.splitlines() if line.strip().startswith(env_id)]
        assert row.rstrip().endswith(tuple("0123456789"))  # the real-time factor closes the row
    assert "sync:" in out and "async:" in out


def test_sim_bench_targets_quick(capsys):
    from magsoft_env.bench import sim_bench

    assert sim_bench.main(["--quick", "--only", "targets", "--rounds", "2"]) == 0
    out = capsys.readouterr().out
    assert "all timing targets met in the same round" in out and "/2 rounds" in out
    for prefix in ("  A:", "    5c:"):
        (row,) = _rows(out, prefix)
        cells = row.split(":", 1)[1].split()
        met_floor, dq, met_rtf = cells[-14], cells[-13], cells[-9]
        assert met_floor.endswith("/2") and met_rtf.endswith("/2")
        assert float(dq) == 0.0  # the C replay follows the Simulator's trajectory exactly
        crawl, fine, d_fine = (float(v) for v in cells[-8:-5])
        assert crawl * fine > 0
        rounding = 100 * 5e-4 * (1 / abs(fine) + abs(crawl) / fine**2) + 0.05  # mm printed to 3 decimals
        assert d_fine == pytest.approx(100 * (crawl - fine) / fine, abs=rounding)


def test_sim_bench_reference_quick(capsys):
    from magsoft_env.bench import sim_bench

    assert sim_bench.main(["--quick", "--only", "reference"]) == 0
    out = capsys.readouterr().out
    for crawler in (" A:", " 5c:"):
        euler = [r.split() for r in _rows(out, crawler) if r.split()[1:2] == ["euler"] and "Rich." not in r]
        assert [float(r[2]) for r in euler] == [10.0, 5.0, 2.5]
        shape = [float(r[4]) for r in euler]
        assert shape[0] > shape[1] > shape[2] > 0  # Euler closes in on the discrete fine-step run


def test_sim_bench_sweep_quick(capsys):
    from magsoft_env.bench import sim_bench

    assert sim_bench.main(["--quick", "--only", "sweep"]) == 0
    lines = [r.split() for r in capsys.readouterr().out.splitlines()]
    rows = [r for r in lines if r[:1] in (["10"], ["20"]) and r[1] in ("discrete", "euler")]
    assert len(rows) == 8  # 2 N x 2 integrators x 2 timesteps in --quick
    floor = [r for r in lines if r[:1] in (["10"], ["20"]) and len(r) == 8]
    assert len(floor) == 4  # 2 N x 2 timesteps
    for _, _, crawl, ref, _, shape, _, _ in floor:
        assert float(crawl) * float(ref) > 0 and float(shape) >= 0
    fine = {(n, float(dt)): float(shape) for n, dt, _, _, _, shape, _, _ in floor}
    assert all(fine[(n, 1e-4)] < fine[(n, 1e-3)] for n in ("10", "20"))
    static = {}
    for n, _, _, st, dyn, _, rtf in rows:
        static.setdefault(n, set()).add(st)
        assert 0 < float(dyn) < 10 and float(rtf) > 0
    # the settled state is the discrete equilibrium whatever the integrator and step, and it is
    # second order in the segment length (elastica closed form, docs/sim.md "Static error")
    assert all(len(v) == 1 for v in static.values())
    assert float(static["10"].pop()) / float(static["20"].pop()) == pytest.approx(4.0, rel=0.1)
    by_dt = {(n, integ, float(dt)): float(dyn) for n, integ, dt, _, dyn, _, _ in rows}
    for n in ("10", "20"):
        for integ in ("discrete", "euler"):
            assert by_dt[(n, integ, 2e-4)] < by_dt[(n, integ, 1e-3)]  # the smaller step is closer


def test_batch_bench_quick(capsys):
    from magsoft_env.bench import batch_bench

    assert batch_bench.main(["--quick", "--engines", "local", "--equilibria", "6", "--gaits", "1", "--noops", "5"]) == 0
    rows = _rows(capsys.readouterr().out, ("      noop", "equilibria", "     gaits"))
    assert len(rows) == 6 and all(r.split()[-1] == "True" for r in rows)  # every engine's rows equal the serial ones
