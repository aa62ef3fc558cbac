"""The SJTU letters (paper Fig. 4e): one-stroke targets and a designed letter."""

import math

import numpy as np
import pytest

import magsoft_env as ms
from magsoft_env.design import validate_target
from magsoft_env.design.letters import LETTERS, design_letters, letter_target


@pytest.mark.parametrize("letter", list(LETTERS))
def test_letter_targets_are_valid_strokes_from_the_clamp(letter):
    xz = letter_target(letter)
    validate_target(xz)
    assert np.allclose(xz[0], 0.0)
    d = xz[1] - xz[0]
    assert math.degrees(math.atan2(d[1], d[0])) == pytest.approx(LETTERS[letter][0], abs=1.0)


def test_unknown_letter():
    with pytest.raises(ValueError, match="letter must be one of"):
        letter_target("X")


@pytest.mark.slow
def test_designed_j_forms_the_letter():
    res = design_letters("J")["J"]
    assert res.success and res.rms_error < 0.005 * res.beam.length
    # the designed beam, solved again from scratch, follows the stroke
    eq = ms.solve_equilibrium(res.beam, res.field, clamp_angle=res.settings["clamp_angle_rad"])
    assert eq.success
