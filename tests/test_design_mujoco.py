"""A designed beam simulated in MuJoCo under the designed field matches the analytical shape."""

import numpy as np
import pytest

import magsoft_env as ms
from magsoft_env.compare import mujoco_check
from magsoft_env.design import builtin_target

pytest.importorskip("mujoco")


def test_designed_ball_gripper_in_mujoco_matches_analytical_shape():
    beam = ms.Beam(length=1.0, width=5e-3, thickness=1.13e-3)
    res = ms.design_profile(builtin_target("ball"), beam, field_bounds=(1e-3, 20e-3), n_points=25, n_starts=1,
                            max_nfev=20)
    chk = mujoco_check(res, segments=20)
    assert chk["success"], chk["message"]
    L = res.beam.length
    # 20-link hinge chain: static errors of a few 0.1 % of L against the continuum (docs/sim.md)
    assert chk["max_to_analytical"] < 0.005 * L
    assert chk["sim_xz"].shape == (22, 2) and np.allclose(chk["sim_xz"][0], 0.0, atol=1e-9)


def test_mujoco_check_rejects_paper_coupling_designs():
    beam = ms.Beam(length=1.0, width=5e-3, thickness=1.13e-3)
    res = ms.design_profile(builtin_target("ball"), beam, field_bounds=(1e-3, 20e-3), n_points=10, n_starts=1,
                            max_nfev=2, coupling="paper")
    with pytest.raises(ValueError, match="coupling='rotated'"):
        mujoco_check(res)
