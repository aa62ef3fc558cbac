"""The 3D specification: fields (B_x, B_y, B_z), magnetization directions, the rod's three stiffnesses."""

import math
import pickle

import numpy as np
import pytest

import magsoft_env as ms
from magsoft_env.cases import Robot, load_robot
from magsoft_env.cases.beamfile import beam_from_dict, beam_to_dict
from magsoft_env.spec import Direction, as_field, as_fields, planar_field
from magsoft_env.spec.field import field_pair

PAPER = {"length": 25e-3, "width": 5e-3, "thickness": 1.13e-3}
ACROSS = (0.0, ms.PiecewiseConstant([1.0, -1.0]), 0.0)  # across the width, flipping at mid-length


def paper_beam(**kw) -> ms.Beam:
    return ms.Beam(**PAPER, **kw)


# ------------------------------------------------------------------------------------------- fields


def test_two_components_mean_bx_bz_and_three_mean_bx_by_bz():
    assert ms.Field(1e-3, 2e-3).vector().tolist() == [1e-3, 0.0, 2e-3]
    assert ms.Field(1e-3, 2e-3, 3e-3).vector().tolist() == [1e-3, 2e-3, 3e-3]
    assert ms.Field(By=4e-3).vector().tolist() == [0.0, 4e-3, 0.0]
    assert ms.Field(1e-3, 2e-3, By=5e-3) == ms.Field(1e-3, 5e-3, 2e-3)
    assert as_field((1e-3, 2e-3)) == ms.Field(Bx=1e-3, Bz=2e-3)
    assert as_field([1e-3, 2e-3, 3e-3]) == ms.Field(Bx=1e-3, By=2e-3, Bz=3e-3)


def test_from_mT_takes_two_or_three_components():
    assert ms.Field.from_mT(-22, 13).vector() == pytest.approx([-22e-3, 0.0, 13e-3], rel=1e-15)
    f = ms.Field.from_mT(3, 4, 12)
    assert (f.Bx, f.By, f.Bz) == (3 * 1e-3, 4 * 1e-3, 12 * 1e-3)
    assert f.magnitude == pytest.approx(13e-3, rel=1e-14)  # 3-4-12-13
    assert ms.Field.from_mT(By_mT=2).By == 2e-3


def test_planar_field_keeps_its_pair_and_a_3d_one_refuses_it():
    f = ms.Field.from_mT(3, 4)
    assert f.is_planar and tuple(f) == (3e-3, 4e-3) and f.as_array().tolist() == [3e-3, 4e-3]
    assert f.magnitude == pytest.approx(5e-3, rel=1e-14)
    g = ms.Field(0.0, 1e-3, 1e-3)
    assert not g.is_planar
    assert g.angle == pytest.approx(math.pi / 2)  # of the x-z projection
    with pytest.raises(ValueError, match=r"has B_y = 0.001 T; this quantity is planar .*Field.vector\(\)"):
        g.as_array()
    with pytest.raises(ValueError, match=r"has B_y = 0.001 T"):
        tuple(g)


def test_ramp_interpolates_all_three_components():
    fields = ms.ramp((0.0, 0.0), (2e-3, 4e-3, 6e-3), 3)
    assert [f.vector().tolist() for f in fields] == [[0, 0, 0], [1e-3, 2e-3, 3e-3], [2e-3, 4e-3, 6e-3]]
    assert [f.By for f in ms.ramp((0, 0), (0, 4e-3, 0), 2, include_start=False)] == [2e-3, 4e-3]


def test_as_fields_takes_arrays_of_two_or_three_columns():
    two = as_fields(np.array([[1e-3, 2e-3], [3e-3, 4e-3]]))
    three = as_fields(np.array([[1e-3, 2e-3, 3e-3]]))
    assert two[1] == ms.Field(3e-3, 4e-3) and three[0] == ms.Field(1e-3, 2e-3, 3e-3)
    assert as_fields([(1e-3, 2e-3), (1e-3, 2e-3, 3e-3)])[1].By == 2e-3
    with pytest.raises(ValueError, match=r"shape \(n, 2\) rows \(B_x, B_z\) or \(n, 3\).*got \(2, 4\)"):
        as_fields(np.zeros((2, 4)))


@pytest.mark.parametrize("make, message", [
    (lambda: ms.Field(1, 2, 3, 4), r"Field takes at most three components .*got 4"),
    (lambda: ms.Field.from_mT(1, 2, 3, 4), r"Field.from_mT takes at most three components"),
    (lambda: ms.Field(1e-3, Bx=2e-3), r"Field got Bx both by position and by keyword"),
    (lambda: ms.Field(Bq=1e-3), r"unknown keyword\(s\) \['Bq'\]"),
    (lambda: ms.Field(0, 2.0, 0), r"field By must lie in \[-1, 1\] T, got 2.0"),
    (lambda: as_field((0, 13, 0)), r"field By must lie in \[-1, 1\] T, got 13"),
    (lambda: as_field((1e-3,)), r"pair \(B_x, B_z\) in tesla \(or a triple \(B_x, B_y, B_z\)"),
])
def test_field_errors(make, message):
    with pytest.raises(ValueError, match=message):
        make()


def test_planar_parts_name_themselves_and_the_3d_model():
    with pytest.raises(ValueError, match=r"preset files take planar fields .*solve_equilibrium.*\(B_x, B_y, B_z\)"):
        field_pair("path[0] field_mT", [0, 1, 2], "[B_x, B_z] in mT", planar="preset files")
    with pytest.raises(ValueError, match=r"the MuJoCo hinge-chain rod is planar .*B_y = 0.002 T.*3D analytical"):
        planar_field(ms.Field(0, 2e-3, 0), "the MuJoCo hinge-chain rod")
    assert planar_field(ms.Field(1e-3, 0.0), "x") == ms.Field(1e-3, 0.0)


def test_groups_use_the_3d_magnitude():
    beam = paper_beam()
    planar = beam.nondimensional_groups((0.0, 13e-3))
    tilted = beam.nondimensional_groups((0.0, 5e-3, 12e-3))  # |B| = 13 mT
    assert tilted["Lambda"] == pytest.approx(planar["Lambda"], rel=1e-12)
    assert tilted["alpha_deg"] == pytest.approx(90.0)


# ------------------------------------------------------------------------------------ material, section


@pytest.mark.parametrize("nu", [0.0, 0.3, 0.5])
def test_poisson_ratio_range_and_shear_modulus(nu):
    m = ms.Material(poisson_ratio=nu)
    assert m.shear_modulus(0.2) == pytest.approx(m.youngs_modulus(0.2) / (2.0 * (1.0 + nu)), rel=1e-15)
    assert ms.Material().poisson_ratio == 0.49


@pytest.mark.parametrize("nu", [-0.1, 0.51, 1.0, math.nan])
def test_poisson_ratio_outside_the_elastomer_range_is_refused(nu):
    with pytest.raises(ValueError, match=r"Material.poisson_ratio must (lie in \[0, 0.5\]|be a finite number)"):
        ms.Material(poisson_ratio=nu)


def test_torsion_constant_of_the_paper_strip():
    assert paper_beam().torsion_constant == pytest.approx(2.062e-12, rel=5e-4)


def test_torsion_constant_square_and_thin_strip_limits():
    a = 2e-3
    assert ms.Beam(25e-3, a, a).torsion_constant / a**4 == pytest.approx(0.1406, abs=5e-5)
    a, b = 10e-3, 1e-3
    thin = a * b**3 / 3.0 * (1.0 - 0.630 * b / a)
    assert ms.Beam(25e-3, a, b).torsion_constant == pytest.approx(thin, rel=1e-4)
    # J does not depend on which side is the width
    assert ms.Beam(0.1, b, a).torsion_constant == pytest.approx(ms.Beam(0.1, a, b).torsion_constant, rel=1e-14)


def test_stiffnesses_of_the_paper_strip():
    beam = paper_beam(volume_fraction=ms.PiecewiseConstant([0.1, 0.2]))
    s = np.array([5e-3, 20e-3])
    k = beam.stiffnesses(s)
    assert k.shape == (2, 3)
    i_w, i_s = beam.second_moments
    assert (i_w, i_s) == (pytest.approx(5e-3 * 1.13e-3**3 / 12), pytest.approx(1.13e-3 * 5e-3**3 / 12))
    assert i_w == beam.second_moment
    assert k[:, 1] / k[:, 0] == pytest.approx([(5 / 1.13) ** 2] * 2, rel=1e-12)
    assert k[0, 1] / k[0, 0] == pytest.approx(19.6, abs=0.05)
    E = beam.youngs_modulus(s)
    assert k[:, 0] == pytest.approx(E * i_w, rel=1e-15)
    assert k[:, 2] == pytest.approx(E / (2 * 1.49) * 2.0623e-12, rel=1e-4)


# ------------------------------------------------------------------------------ magnetization direction


def test_direction_is_normalized_pointwise():
    d = Direction(3.0, 0.0, ms.PiecewiseLinear([0.0, 0.02], [4.0, -4.0]))
    v = d.vectors(np.array([0.0, 0.01, 0.02]), 0.02)
    assert v == pytest.approx(np.array([[0.6, 0.0, 0.8], [1.0, 0.0, 0.0], [0.6, 0.0, -0.8]]), abs=1e-15)


def test_direction_cells_per_component_and_their_breakpoints():
    beam = paper_beam(magnetization=(ms.PiecewiseConstant([1.0, 0.0], [1, 4]), ACROSS[1], 0.0),
                      volume_fraction=ms.PiecewiseConstant([0.1, 0.2, 0.2]))
    assert beam.breakpoints() == pytest.approx((5e-3, 25e-3 / 3, 12.5e-3), rel=1e-15)  # all cells
    v = beam.magnetization_direction([1e-3, 10e-3, 20e-3])
    r = math.sqrt(0.5)
    assert v == pytest.approx(np.array([[r, r, 0.0], [0.0, 1.0, 0.0], [0.0, -1.0, 0.0]]), abs=1e-15)
    assert not beam.is_planar


def test_direction_spline_knots_are_the_union_of_the_components():
    d = Direction(ms.Sampled([0.0, 0.01, 0.02, 0.03], [1, 2, 1, 2]), ms.Sampled([0.0, 0.015, 0.025, 0.03],
                                                                                  [0, 1, 0, 1]), 0.0)
    assert d.spline_knots(0.025) == (0.01, 0.015, 0.02)
    assert paper_beam(magnetization=d).spline_knots() == (0.01, 0.015, 0.02)


def test_direction_components_take_numbers_callables_and_profiles():
    k = 2 * np.pi / 25e-3
    beam = paper_beam(magnetization=(lambda s: np.cos(k * s), 0.0, lambda s: np.sin(k * s)))
    s = np.linspace(0.0, 25e-3, 7)
    assert beam.beta(s) == pytest.approx(np.arctan2(np.sin(k * s), np.cos(k * s)))
    assert isinstance(beam.magnetization.axial, ms.Function)


def test_zero_direction_is_refused():
    with pytest.raises(ValueError, match=r"non-zero vector everywhere .*got \(0, 0, 0\) at s = 12.5 mm"):
        paper_beam(magnetization=(ms.PiecewiseConstant([1.0, 0.0]), 0.0, 0.0))
    with pytest.raises(ValueError, match=r"got \(0, 0, 0\) at s = 0 mm"):
        paper_beam(magnetization=(0, 0, 0))
    with pytest.raises(ValueError, match=r"Direction is the zero vector at s = 5 mm"):
        Direction(0.0, 0.0, ms.PiecewiseConstant([0.0, 1.0])).vectors([0.005, 0.015], 0.04)


@pytest.mark.parametrize("value, message", [
    ((0.1, 0.2), r"Beam.magnetization must be a number, a callable .* three of those, got 2 entries: \(0.1, 0.2\)"),
    ([1, 0, 0, 0], r"got 4 entries"),
    ((1, "a", 0), r"Beam.magnetization width must be a number"),
    ((1, math.inf, 0), r"Beam.magnetization width must be a finite number"),
])
def test_magnetization_sequences_other_than_a_direction_are_refused(value, message):
    with pytest.raises(ValueError, match=message):
        paper_beam(magnetization=value)


def test_a_planar_direction_reduces_to_beta():
    s = np.linspace(0.0, 25e-3, 5)
    assert paper_beam(magnetization=(1, 0, 0)).beta(s).tolist() == [0.0] * 5
    up = paper_beam(magnetization=(0, 0, 1))
    assert up.is_planar and up.beta(s) == pytest.approx([math.pi / 2] * 5, abs=1e-15)
    assert up.magnetization_direction(s) == pytest.approx(np.tile([0.0, 0.0, 1.0], (5, 1)), abs=1e-15)
    angle = paper_beam(magnetization=0.3)
    assert angle.is_planar
    assert angle.magnetization_direction([0.0])[0] == pytest.approx([math.cos(0.3), 0.0, math.sin(0.3)], rel=1e-15)


def test_a_width_component_refuses_beta():
    beam = paper_beam(magnetization=ACROSS)
    assert not beam.is_planar
    with pytest.raises(ValueError, match=r"component across the width; the planar model .* use the 3D solver"):
        beam.beta([0.0])
    with pytest.raises(ValueError, match=r"the MuJoCo hinge-chain rod is planar .*across the width"):
        beam.require_planar("the MuJoCo hinge-chain rod")
    with pytest.raises(ValueError, match=r"Direction has three components .*Direction.vectors"):
        beam.magnetization.values([0.0], 25e-3)


def test_direction_beams_replace_pickle_and_hash():
    beam = paper_beam(magnetization=ACROSS)
    assert pickle.loads(pickle.dumps(beam)) == beam
    assert hash(beam) == hash(paper_beam(magnetization=ACROSS))
    shorter = beam.replace(length=20e-3)
    assert shorter.breakpoints() == pytest.approx((10e-3,)) and shorter.magnetization == beam.magnetization


# ------------------------------------------------------------------------------------------ robot files


def test_direction_and_poisson_ratio_round_trip_through_a_robot_file(tmp_path):
    beam = paper_beam(
        material=ms.Material(poisson_ratio=0.45),
        magnetization=(ms.PiecewiseLinear([0.0, 12.5e-3, 25e-3], [1.0, 0.3, 1.0]),
                       ms.PiecewiseConstant([1.0, -1.0, 1.0], [1, 2, 1]),
                       ms.Sampled([0.0, 10e-3, 20e-3, 30e-3], [0.0, 1.0, 2.0, 3.0])),
    )
    d = beam_to_dict(beam)
    assert d["material"]["poisson_ratio"] == 0.45
    assert d["magnetization"]["kind"] == "direction"
    assert d["magnetization"]["width"] == {"cells": [1.0, -1.0, 1.0], "fractions": [0.25, 0.5, 0.25]}
    for suffix in (".yml", ".json"):
        robot = Robot("twist", beam)
        assert load_robot(robot.save(tmp_path / f"twist{suffix}")).beam == beam


def test_direction_read_from_a_file_with_expressions_and_defaults():
    d = {"length_mm": 25, "width_mm": 5, "thickness_mm": 1.13,
         "magnetization": {"kind": "direction", "width": {"kind": "expression", "value": "cos(pi * s / 25)"},
                           "thickness": 1}}
    beam = beam_from_dict(d)
    assert beam.material.poisson_ratio == 0.49  # not given: the default
    r = math.sqrt(0.5)
    expected = np.array([[0.0, r, r], [0.0, 0.0, 1.0]])
    assert beam.magnetization_direction([0.0, 12.5e-3]) == pytest.approx(expected, abs=1e-15)
    assert beam_from_dict(beam_to_dict(beam)) == beam


def test_planar_files_read_as_before():
    d = {"length_mm": 25, "width_mm": 5, "thickness_mm": 1.13, "magnetization": {"kind": "uniform", "angle_deg": 90}}
    beam = beam_from_dict(d)
    assert beam.magnetization == ms.Constant(math.pi / 2) and beam.is_planar
    assert beam_to_dict(beam)["magnetization"] == {"kind": "uniform", "angle_deg": 90.0}


@pytest.mark.parametrize("change, message", [
    ({"material": {"poisson_ratio": 0.7}}, r"beam material poisson_ratio must lie in \[0, 0.5\], got 0.7"),
    ({"magnetization": {"kind": "direction", "axil": 1}}, r"unknown key 'axil'.*Did you mean 'axial'"),
    ({"magnetization": {"kind": "direction", "width": {"kind": "expression", "phi": "s"}}},
     r"beam magnetization width has unknown key 'phi'; allowed: \['kind', 'value', 'kinks_s_mm'\]"),
    ({"magnetization": {"kind": "direction", "axial": "1"}}, r"beam magnetization axial must be a number"),
    ({"magnetization": {"kind": "direction"}}, r"non-zero vector everywhere"),
])
def test_direction_file_errors(change, message):
    d = {"length_mm": 25, "width_mm": 5, "thickness_mm": 1.13, **change}
    with pytest.raises(ValueError, match=message):
        beam_from_dict(d)


def test_robot_design_field_stays_planar():
    with pytest.raises(ValueError, match=r"Robot.design_field \(a planar design's held field\) is planar"):
        Robot("r", paper_beam(), design_field=(0.0, 1e-3, 1e-3))


# ------------------------------------------------------------------------------------- planar consumers


def test_mujoco_rod_refuses_a_width_magnetization_and_a_y_field():
    pytest.importorskip("mujoco")
    from magsoft_env.sim import Simulator, mujoco_equilibrium
    from magsoft_env.sim.discretize import discretize
    from magsoft_env.sim.waveforms import Hold

    across = paper_beam(magnetization=ACROSS)
    for call in (lambda: Simulator(across), lambda: discretize(across, 10),
                 lambda: mujoco_equilibrium(across, (0.0, 1e-3))):
        with pytest.raises(ValueError, match=r"the MuJoCo hinge-chain rod is planar .*across the width"):
            call()
    with pytest.raises(ValueError, match=r"the MuJoCo hinge-chain rod is planar .*B_y = 0.001 T"):
        mujoco_equilibrium(paper_beam(), (0.0, 1e-3, 1e-3))
    held = Hold((0.0, 2e-3, 0.0))  # a three-axis waveform (the 3D rod takes it), refused by the planar rod
    assert held.components == 3
    sim = Simulator(paper_beam(magnetization=(1, 0, 0)), field=(0.0, 1e-3))
    with pytest.raises(ValueError, match=r"hinge-chain rod takes fields in the x-z plane.*up to 2 mT"):
        sim.set_waveform(held)
    assert sim.field == ms.Field(0.0, 1e-3)
    with pytest.raises(ValueError, match=r"hinge-chain rod is planar .*B_y = 0.003 T"):
        sim.set_field(ms.Field(0.0, 3e-3, 0.0))


def test_gaits_and_grasp_refuse_a_width_magnetization():
    pytest.importorskip("mujoco")
    from magsoft_env.compare.grasp import GraspScene, hanging_target
    from magsoft_env.sim.gait import gait_rod_options

    across = paper_beam(magnetization=ACROSS)
    with pytest.raises(ValueError, match=r"robot 'twist' on the MuJoCo hinge-chain rod .* is planar"):
        gait_rod_options(Robot("twist", across))
    with pytest.raises(ValueError, match=r"the grasp scene \(planar MuJoCo fingers\) is planar"):
        GraspScene(across, (0.0, 5e-3), hanging_target("ball"))
    with pytest.raises(ValueError, match=r"the grasp scene \(planar MuJoCo fingers\) is planar .*B_y"):
        GraspScene(paper_beam(), (0.0, 1e-3, 5e-3), hanging_target("ball"))


def test_direction_of_python_functions_is_saved_as_samples():
    beam = paper_beam(magnetization=(lambda s: 1.0 + 0.0 * s, lambda s: np.sin(300.0 * s), 0.2))
    with pytest.raises(ValueError, match=r"beam magnetization axial is a Function of a Python function"):
        beam_to_dict(beam)
    back = beam_from_dict(beam_to_dict(beam, sample_functions=True))
    s = np.linspace(0.0, 25e-3, 101)
    assert back.magnetization_direction(s) == pytest.approx(beam.magnetization_direction(s), abs=1e-8)


def test_crosscheck_and_field_controls_refuse_what_is_not_planar():
    pytest.importorskip("mujoco")
    from magsoft_env.cases.statics import PathSegment, Preset
    from magsoft_env.compare import crosscheck_preset
    from magsoft_env.sim.model import field_controls

    def preset(beam, end):
        return Preset("p", "d", beam, (PathSegment(ms.Field(), end, 2),))

    with pytest.raises(ValueError, match=r"crosscheck_preset \(preset 'p' on the MuJoCo hinge-chain rod\) is planar"):
        crosscheck_preset(preset(paper_beam(magnetization=ACROSS), ms.Field(0.0, 1e-3)))
    with pytest.raises(ValueError, match=r"crosscheck_preset .* B_y = 0.001 T"):
        crosscheck_preset(preset(paper_beam(), ms.Field(0.0, 1e-3, 0.0)))
    with pytest.raises(ValueError, match=r"field_controls takes planar fields \(B_x, B_z\).*got shape \(4, 3\)"):
        field_controls(np.zeros((4, 3)))
    mag, _ = field_controls([(3e-3, 4e-3)])
    assert mag.tolist() == [pytest.approx(5e-3, rel=1e-15)]
