"""Time against error (bench/frontier.py) and the env-defaults acceptance check (bench/env_defaults.py): the
frontier and knee logic on synthetic grids, the scenes' placement, and that the env plays a gait exactly as
run_gait does (one physics)."""

import json

import pytest

from magsoft_env.bench.crawl_convergence import parse_scene
from magsoft_env.bench.frontier import frontier_rows, knee


def _row(n, d, x, wall):
    return {"gait": "g", "segments": n, "timestep_ms": d, "success": True, "displacement_mm": x, "speed_mm_s": x,
            "wall_per_sim_s": wall}


def test_frontier_marks_only_points_no_cheaper_point_beats():
    # x(N, dt) = 1 + 0.04 dt + 1 / N^2, cost N / dt: the reference is the finest N, extrapolated in dt
    grid = {("g", n, d): _row(n, d, 1.0 + 0.04 * d + 1.0 / n**2, n / d) for n in (10, 20, 40) for d in (0.4, 0.2, 0.1)}
    rows, refs = frontier_rows(grid, "g")
    assert [r["wall_per_sim_s"] for r in rows] == sorted(r["wall_per_sim_s"] for r in rows)
    best = float("inf")
    assert sum(r["reference"] for r in rows) == 1  # the reference's own run: shown, not counted
    assert [(r["segments"], r["timestep_ms"]) for r in rows if r["reference"]] == [(40, 0.1)]
    for r in rows:
        assert r["frontier"] == (not r["reference"] and r["error"] < best)
        best = best if r["reference"] else min(best, r["error"])
    assert rows[0]["frontier"]  # the cheapest point is always on it
    assert refs["displacement_mm"]["value"] == pytest.approx(1.0 + 1.0 / 1600)
    k = knee(rows, tolerance=0.02)
    assert k["error"] <= 0.02 and k["robust"] and not k["reference"]
    finer = [r for r in rows if r["segments"] == k["segments"] and r["timestep_ms"] < k["timestep_ms"]]
    assert max(finer, key=lambda r: r["timestep_ms"])["error"] <= 0.02
    assert knee(rows, tolerance=1e-9) is None


def test_knee_falls_back_to_a_lucky_point_and_says_so():
    rows = [{"segments": 10, "timestep_ms": 0.2, "wall_per_sim_s": 1.0, "error": 0.01},
            {"segments": 10, "timestep_ms": 0.1, "wall_per_sim_s": 2.0, "error": 0.3}]
    k = knee(rows, tolerance=0.05)
    assert (k["timestep_ms"], k["robust"]) == (0.2, False)


def test_scene_option_is_checked():
    assert parse_scene("channel") == {"scene": "channel", "feature_x": -8.5e-3}
    assert parse_scene("obstacle:-6") == {"scene": "obstacle", "feature_x": pytest.approx(-6e-3)}
    for bad in ("tunnel", "channel:x", "obstacle:nan"):
        with pytest.raises(ValueError, match="--scene"):
            parse_scene(bad)


def test_env_plays_a_gait_as_run_gait_does():
    # the acceptance check runs the gaits through the env: the env's waveform mode with the robot's drive is the
    # same physics as run_gait at the same numerics (agreement to round-off accumulated over 2 s)
    from magsoft_env.bench.env_defaults import env_gait
    from magsoft_env.sim.gait import run_gait

    e = env_gait("paper-5c", 2.0, segments=10, sim_dt=4e-4)
    g = run_gait("paper-5c", 2.0, segments=10, timestep=4e-4)
    assert e["success"] and g.success
    assert (e["segments"], e["timestep_ms"]) == (g.segments, g.timestep * 1e3) == (10, 0.4)
    assert e["displacement_mm"] == pytest.approx(g.displacement * 1e3, rel=1e-4)
    assert e["speed_mm_s"] == pytest.approx(g.speed * 1e3, rel=1e-4)


@pytest.mark.slow
def test_frontier_quick_runs_every_scene_and_draws(tmp_path):
    from magsoft_env.bench import frontier

    out, png, cache = tmp_path / "f.json", tmp_path / "f.png", tmp_path / "runs.json"
    assert frontier.main(["--quick", "--cache", str(cache), "--json", str(out), "--plot", str(png)]) == 0
    data = json.loads(out.read_text())
    assert set(data) == {"floor", "channel", "obstacle"}
    assert set(data["floor"]) == {"paper-5a", "paper-5b", "paper-5c"}
    for per_robot in data.values():
        for res in per_robot.values():
            assert len(res["rows"]) == 4 and any(r["frontier"] for r in res["rows"])
    assert png.stat().st_size > 10_000
    runs = json.loads(cache.read_text())
    assert frontier.main(["--quick", "--cache", str(cache), "--cached-only"]) == 0  # tabulates without running
    assert json.loads(cache.read_text()) == runs


def test_feature_cost_variants_that_skip_work_leave_the_crawl_unchanged():
    # bench/feature_cost.py: the features the model skips or could skip (broad phase vs explicit pairs, islands,
    # the penetration sensor, the Jacobian's storage) must not change the trajectory; the cone and noslip do
    from magsoft_env.bench.feature_cost import feature_costs

    rows = {r["variant"]: r for r in feature_costs("paper-5c", seconds=0.1, rounds=1, fidelity="fast")}
    assert all(r["finite"] and r["us_per_step"] > 0 for r in rows.values())
    for name in ("broad phase instead of explicit pairs", "islands on", "contact sensor off", "dense Jacobian",
                 "solver 20 iterations"):
        assert abs(rows[name]["displacement_change_mm"]) < 1e-9, name
    assert abs(rows["noslip 10"]["displacement_change_mm"]) > 1e-9  # it changes the friction solve
