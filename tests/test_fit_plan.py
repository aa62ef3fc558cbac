"""Planning the measurements of a fit: the predicted precision is the fit's own, and it holds over noise draws."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import magsoft_env as ms

BEAM = ms.Beam(25e-3, 5e-3, 1.13e-3)
PARAMS = ("E0", "particle_magnetization")


@pytest.fixture(scope="module")
def plan():
    return ms.plan_measurements(BEAM, PARAMS, n=6, noise=1e-4)


def _data(truth, fields, noise, rng):
    out = []
    for B in fields:
        tip = ms.solve_equilibrium(truth, B, gravity=9.81, model="planar").tip_position[[0, 2]]
        out.append((B, tip + (rng.normal(scale=noise, size=2) if noise else 0.0)))
    return out


def test_plan_picks_distinct_fields_gravity_first(plan):
    assert len(plan.fields) == 6 and plan.fields[0] == (0.0, 0.0)
    assert len(set(plan.fields)) == 6
    assert all(np.hypot(*f) <= 4e-3 * (1 + 1e-12) for f in plan.fields)
    assert all(lam >= 0.5 for lam in plan.min_eigenvalue)
    assert plan.candidates == 8 * 24 + 1
    assert "predicted 1-sigma" in plan.table()


def test_prediction_is_the_fits_sigma_at_the_truth(plan):
    # noise-free data from the guess itself: the fit stops at the guess, and its sigma (noise given) is the plan's
    res = ms.fit(BEAM, _data(BEAM, plan.fields, 0.0, None), params=PARAMS, sigma=1e-4, restarts=0)
    for p in PARAMS:
        assert res.sigma[p] == pytest.approx(plan.sigma[p], rel=1e-6)
        assert plan.relative_sigma[p] == pytest.approx(plan.sigma[p] / res.values[p], rel=1e-6)


def test_planned_fields_beat_random_ones_of_the_same_number(plan):
    rng = np.random.default_rng(4)
    worse = 0
    for _ in range(5):
        a = rng.uniform(0, 2 * np.pi, 5)
        m = rng.uniform(0.5e-3, 4e-3, 5)
        fields = [(0.0, 0.0)] + [(float(b * np.cos(t)), float(b * np.sin(t))) for b, t in zip(m, a, strict=True)]
        rand = ms.predict_precision(BEAM, fields, PARAMS, noise=1e-4)
        worse += max(rand.relative_sigma.values()) > max(plan.relative_sigma.values())
    assert worse == 5


def test_predicted_sigma_matches_the_scatter_of_fits(plan):
    """Fits of 24 noise draws on a truth 20 % off the guess: their spread is the predicted sigma (within the
    sampling error of 24 draws, about +-15 % on a standard deviation)."""
    mat = BEAM.material
    mat = dataclasses.replace(mat, E0=1.2 * mat.E0, particle_magnetization=0.85 * mat.particle_magnetization)
    truth = dataclasses.replace(BEAM, material=mat)
    pred = ms.predict_precision(truth, plan.fields, PARAMS, noise=1e-4)
    rng = np.random.default_rng(11)
    logs = []
    for _ in range(24):
        res = ms.fit(BEAM, _data(truth, plan.fields, 1e-4, rng), params=PARAMS, restarts=0)
        assert res.success
        true = (mat.E0, mat.particle_magnetization)
        logs.append([np.log(res.values[p] / v) for p, v in zip(PARAMS, true, strict=True)])
    sd = np.std(np.array(logs), axis=0, ddof=1)
    for p, s in zip(PARAMS, sd, strict=True):
        assert 0.6 < s / pred.relative_sigma[p] < 1.5, (p, s, pred.relative_sigma[p])


def test_without_gravity_the_pair_is_refused():
    with pytest.raises(ValueError, match="not identifiable"):
        ms.predict_precision(BEAM, [(0.0, 1e-3), (1e-3, 0.0), (-1e-3, 1e-3)], PARAMS, gravity=0.0)


@pytest.mark.parametrize("kw, match", [
    ({"n": 1}, "n .the measurements to plan. must be an integer in \\[2, 100\\], got 1"),
    ({"noise": -1e-4}, "noise must be the tracking noise in m"),
    ({"noise": float("nan")}, "noise must be"),
    ({"max_field": 0.0}, "max_field must be a field magnitude in \\(0, 1\\] T, got 0.0"),
    ({"spread": 1.5}, "spread"),
    ({"margin": 0.0}, "margin must be a positive eigenvalue"),
    ({"params": ("E0", "shear")}, "cannot plan for \\['shear'\\]"),
    ({"params": ("E0", "E0")}, "distinct"),
    ({"n": 500}, "n .the measurements to plan. must be an integer"),
    ({"gravity": -1.0}, "gravity must be in \\[0, 1000\\]"),
    ({"s": [0.0]}, "arc lengths"),
])
def test_bad_input_is_refused_before_work(kw, match):
    args = {"params": PARAMS, **kw}
    with pytest.raises(ValueError, match=match):
        ms.plan_measurements(BEAM, **args)


def test_predict_precision_takes_a_3d_field_in_3d():
    plan = ms.predict_precision(BEAM, [(0.0, 0.0), (0.0, 1e-3, 1e-3), (1e-3, 0.0, 2e-3)], PARAMS)
    assert all(len(f) == 3 for f in plan.fields) and "B_y mT" in plan.table()


def test_cli_plan_then_fit_round_trip(tmp_path, capsys):
    """magsoft fit-plan writes the fields; with the tracked tips filled in, magsoft fit reads the same file."""
    import csv
    import json

    from magsoft_env.cli import main

    path, fig = tmp_path / "plan.csv", tmp_path / "plan.png"
    assert main(["fit-plan", "--robot", "paper-5b", "--n", "5", "--noise-mm", "0.05", "--csv", str(path),
                 "--plot", str(fig), "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert len(info["fields_mT"]) == 5 and info["relative_sigma"]["E0"] > 0
    assert info["plot"] == str(fig) and fig.stat().st_size > 10_000
    rows = list(csv.reader(path.open()))
    assert rows[0] == ["Bx_mT", "Bz_mT", "tip_x_mm", "tip_z_mm"] and all(r[2:] == ["", ""] for r in rows[1:])
    robot = ms.load_robot("paper-5b")
    truth = dataclasses.replace(robot.beam, material=dataclasses.replace(robot.beam.material,
                                                                         E0=1.1 * robot.beam.material.E0))
    filled = [rows[0]]
    for bx, bz, _, _ in rows[1:]:
        tip = ms.solve_equilibrium(truth, (float(bx) * 1e-3, float(bz) * 1e-3), gravity=9.81).tip_position * 1e3
        filled.append([bx, bz, f"{tip[0]:.9f}", f"{tip[2]:.9f}"])
    with path.open("w", newline="") as fh:
        csv.writer(fh).writerows(filled)
    assert main(["fit", str(path), "--robot", "paper-5b", "--json"]) == 0
    fit = json.loads(capsys.readouterr().out)
    assert fit["values"]["E0"] == pytest.approx(1.1 * robot.beam.material.E0, rel=1e-6)


def test_cli_plan_refuses_a_bad_noise_before_work(capsys):
    from magsoft_env.cli import main

    assert main(["fit-plan", "--noise-mm", "-1"]) != 0
    assert "--noise-mm must be a positive length" in capsys.readouterr().err
    assert main(["fit-plan", "--plot", "plan.jpg"]) != 0
    assert "--plot must end in one of ['.png']" in capsys.readouterr().err


def test_fit_bench_planned_design_runs(capsys):
    from magsoft_env.bench import fit_bench

    assert fit_bench.main(["--seeds", "1", "--first", "3", "--design", "planned"]) == 0
    out = capsys.readouterr().out
    assert "design: planned" in out and "within 1 %: 1/1" in out


def test_both_directions_plans_pairs_of_reversed_fields():
    plan = ms.plan_measurements(BEAM, PARAMS, n=5, noise=1e-4, both_directions=True, directions=12, magnitudes=4)
    fields = plan.fields[1:]
    assert plan.fields[0] == (0.0, 0.0) and len(fields) == 4
    for a, b in zip(fields[::2], fields[1::2], strict=True):
        assert a == (-b[0] + 0.0, -b[1] + 0.0)
    with pytest.raises(ValueError, match="even number of fields"):
        ms.plan_measurements(BEAM, PARAMS, n=6, both_directions=True)


def test_a_3d_plan_for_the_width_and_poisson_ratio_is_the_3d_fits_precision():
    """In 3D (fields with B_y, x, y, z tracked) the plan reaches the width and the Poisson ratio; its prediction is
    the 3D fit's own sigma at the truth (noise-free data from the guess, the noise given)."""
    params = ("E0", "particle_magnetization", "width", "poisson_ratio")
    plan = ms.plan_measurements(BEAM, params, n=6, noise=5e-5, model="3d", directions=8, magnitudes=2)
    assert plan.fields[0] == (0.0, 0.0, 0.0) and all(len(f) == 3 for f in plan.fields)
    assert any(f[1] != 0.0 for f in plan.fields)
    assert "B_y mT" in plan.table()
    data = [(f, ms.solve_equilibrium(BEAM, f, gravity=9.81, model="3d").tip_position) for f in plan.fields]
    res = ms.fit(BEAM, data, params=params, sigma=5e-5, restarts=0, model="3d")
    for p in params:
        assert res.sigma[p] == pytest.approx(plan.sigma[p], rel=1e-6), p
    again = ms.predict_precision(BEAM, plan.fields, params, noise=5e-5)  # auto: 3D for these parameters
    for p in params:
        assert again.sigma[p] == pytest.approx(plan.sigma[p], rel=1e-12), p


def test_width_and_poisson_ratio_need_the_3d_model():
    with pytest.raises(ValueError, match="need.s. the 3D model"):
        ms.plan_measurements(BEAM, ("E0", "width"), n=4)
    with pytest.raises(ValueError, match="B_y"):
        ms.predict_precision(BEAM, [(0.0, 0.0), (0.0, 1e-3, 1e-3)], PARAMS, model="planar")


def test_cli_plans_in_3d_with_a_B_y_column(tmp_path, capsys):
    import csv
    import json

    from magsoft_env.cli import main

    path = tmp_path / "plan3.csv"
    assert main(["fit-plan", "--model", "3d", "--params", "E0,particle_magnetization,poisson_ratio", "--n", "4",
                 "--directions", "8", "--magnitudes", "2",
                 "--csv", str(path), "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["model"] == "3d" and all(len(f) == 3 for f in info["fields_mT"])
    rows = list(csv.reader(path.open()))
    assert rows[0] == ["Bx_mT", "By_mT", "Bz_mT", "tip_x_mm", "tip_y_mm", "tip_z_mm"] and len(rows) == 5
