"""The rod benchmark's own solve_bvp formulation of the 3D Kirchhoff rod (written from the equations,
sharing no code with the solver) agrees with ``solve_equilibrium``: an independent check of the 3D
solver on a general case (oblique magnetization, oblique field, gravity); and the benchmark runs."""

import numpy as np
import pytest

import magsoft_env as ms
from magsoft_env.bench import rod_bench


def test_solve_bvp_formulation_agrees_with_the_3d_solver():
    _, beam, fields, g, _ = rod_bench.cases(True)[2]  # case c: magnetization (0.3, 0.8, 0.5), B (1, 2, 5) mT
    res = ms.solve_equilibrium(beam, fields[-1], gravity=g)
    assert res.success and res.stable
    _, (ok, tip, twist, nodes) = rod_bench.bvp_cold(beam, fields[-1], g, 1e-8)
    assert ok
    L = beam.length
    assert np.linalg.norm(tip - res.tip_position / L) < 1e-6
    assert abs(twist - res.tip_twist) < 1e-6
    assert abs(res.tip_twist) > 0.3 and min(abs(res.tip_position[1:])) / L > 0.05  # a genuinely 3D shape


@pytest.mark.slow
def test_rod_bench_quick_runs(capsys):
    assert rod_bench.main(["--quick", "--only", "c", "--rounds", "1"]) == 0
    out = capsys.readouterr().out
    rows = [line for line in out.splitlines() if line.lstrip().startswith("solve_bvp")]
    assert len(rows) == 1
    check = [line for line in out.splitlines() if "vs bvp 1e-10" in line]
    assert len(check) == 1 and "failed" not in check[0]
    tip_err, twist_err = float(check[0].split()[-5]), float(check[0].split()[-2])
    assert tip_err < 1e-9 and twist_err < 1e-9
