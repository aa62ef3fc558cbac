"""The crawl convergence benchmark (docs/convergence.md): its Richardson extrapolation, and its --quick mode
runs and writes a reference with an uncertainty for each paper gait (about 10-20 s)."""

import json
import math

import pytest

from magsoft_env.bench.crawl_convergence import knee, reference, richardson


@pytest.mark.parametrize("order", [1.0, 2.0])
def test_richardson_recovers_the_limit_and_order(order):
    h = [0.4, 0.2, 0.1]
    r = richardson([3.0 + 0.7 * x**order for x in h])
    assert r["regular"]
    assert r["order"] == pytest.approx(order)
    assert r["extrapolated"] == pytest.approx(3.0)
    assert r["error"] == pytest.approx(0.7 * 0.1**order)  # the finest step's own error


def test_richardson_refuses_an_irregular_sequence():
    r = richardson([1.0, 1.3, 1.1])  # not monotone
    assert not r["regular"]
    assert r["extrapolated"] == 1.1 and r["error"] == pytest.approx(0.2)


def _row(gait, n, d, x):
    return {"gait": gait, "segments": n, "timestep_ms": d, "success": True, "displacement_mm": x, "speed_mm_s": x,
            "wall_per_sim_s": n / d}


def test_reference_and_knee_on_a_synthetic_grid():
    # x(N, dt) = 1 + 0.8 dt + 1 / N^2: first order in dt, converged in N to 1 % at N = 40
    grid = {("g", n, d): _row("g", n, d, 1.0 + 0.8 * d + 1.0 / n**2) for n in (10, 20, 40) for d in (0.4, 0.2, 0.1)}
    ref = reference(grid, "g", "displacement_mm")
    assert ref["segments"] == 40
    assert ref["per_segments"][40]["order"] == pytest.approx(1.0)
    assert ref["value"] == pytest.approx(1.0 + 1.0 / 1600)
    assert ref["n_error"] == pytest.approx(1.0 / 400 - 1.0 / 1600)
    table = [{**r, "error_displacement": abs(r["displacement_mm"] / ref["value"] - 1),
              "error_speed": abs(r["speed_mm_s"] / ref["value"] - 1)} for r in grid.values()]
    for r in table:
        r["error"] = max(r["error_displacement"], r["error_speed"])
    k = knee(table, gaits=("g",), tolerance=0.1)
    assert k["error"] <= 0.1
    assert all(r["wall_per_sim_s"] >= k["wall_per_sim_s"] for r in table if r["error"] <= 0.1)


@pytest.mark.slow
def test_quick_mode_writes_references(tmp_path, capsys):
    from magsoft_env.bench import crawl_convergence

    out = tmp_path / "conv.json"
    assert crawl_convergence.main(["--quick", "--json", str(out)]) == 0
    data = json.loads(out.read_text())
    assert set(data["reference"]) == {"paper-5a", "paper-5b", "paper-5c"}
    assert len(data["grid"]) == 3 * 2 * 3
    for refs in data["reference"].values():
        for q in ("displacement_mm", "speed_mm_s"):
            assert math.isfinite(refs[q]["value"]) and refs[q]["uncertainty"] >= 0
    # the cosine-jig crawler goes left at every resolved setting (docs/envs.md)
    assert all(r["speed_mm_s"] < 0 for r in data["grid"] if r["gait"] == "paper-5c" and r["success"])
    assert "| level, gaits |" in capsys.readouterr().out
