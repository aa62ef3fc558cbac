"""Magnetic field sources and their gradients: uniform fields, dipoles, magnets, current loops, coil systems.

A source is anything with ``field_and_gradient(points) -> (B, G)``: ``points`` of shape ``(n, 3)`` in m, ``B`` of
shape ``(n, 3)`` in T and ``G`` of shape ``(n, 3, 3)`` in T/m with ``G[i, a, b] = dB_a / dx_b``. Sources add
(``a + b``). A rod piece of moment ``m`` (A m^2) feels the couple ``m x B`` and the force ``G^T m``.

=====================  ==========================================================================
``Uniform``            a uniform field, ``G = 0`` (the package's original model)
``PointDipole``        a point dipole (exact)
``DipoleSet``          point dipoles summed (exact)
``SphereMagnet``       a uniformly magnetized sphere (exact; uniform inside)
``CylinderMagnet``     an axially magnetized cylinder (exact closed form, inside and outside)
``CuboidMagnet``       a uniformly magnetized cuboid (exact closed form, inside and outside)
``CircularLoop``       a current loop (exact, complete elliptic integrals)
``CoaxialLoops``       loops on one axis, evaluated together (exact)
``helmholtz_pair``     two loops for a uniform field; ``maxwell_pair``: two loops for a uniform gradient
``CoilSystem``         an electromagnetic navigation system from an MPEM calibration, linear in its currents
``GridField``          samples on a grid fitted by a harmonic potential (div- and curl-free)
``MovingSource``       a source whose pose is an input over time; ``Transformed``: at a fixed pose
``SourceSum``          sources added
``CoilDrive``          coil currents as an input: limits, slew rate, L/R lag (exact in discrete time)
``allocate``           least-norm currents for a wanted field (and gradient or force), within the limits
``reachable_field``    the largest field along a direction within the limits (a linear program)
``MagnetWorkspace``    where a permanent magnet may be; ``PosedMagnet``: a magnet whose pose is the input
``load_source``        a source from a calibration name, a YAML/JSON source file or a dict (mm, mT, A in
                       the key names); ``source_from_dict``, ``source_to_dict``, ``save_source``: the same
                       as data, written back exactly (docs/fields.md, "Sources in files")
=====================  ==========================================================================

Everything is SI. docs/fields.md has the formulas, their references and the checks. This unit imports the
root leaves, ``spec``, numpy and scipy (PyYAML when a calibration file is read); importing ``magsoft_env``
does not import it.
"""

from .actuation import Allocation, CoilDrive, MagnetWorkspace, PosedMagnet, Reach, allocate, reachable_field
from .base import MU0_4PI, Source, SourceSum, Transformed, Uniform, as_points
from .coils import ACTUATION_ROWS, CALIBRATIONS, Calibration, CoilSystem, read_mpem
from .dipole import DipoleSet, PointDipole, SphereMagnet
from .files import load_source, save_source, source_from_dict, source_markers, source_to_dict
from .grid import GridField
from .loop import CircularLoop, CoaxialLoops, helmholtz_pair, maxwell_pair
from .magnets import CuboidMagnet, CylinderMagnet
from .moving import MovingSource, rotation_about

__all__ = [
    "ACTUATION_ROWS",
    "CALIBRATIONS",
    "MU0_4PI",
    "Allocation",
    "Calibration",
    "CircularLoop",
    "CoaxialLoops",
    "CoilDrive",
    "CoilSystem",
    "CuboidMagnet",
    "CylinderMagnet",
    "DipoleSet",
    "GridField",
    "MagnetWorkspace",
    "MovingSource",
    "PointDipole",
    "PosedMagnet",
    "Reach",
    "Source",
    "SourceSum",
    "SphereMagnet",
    "Transformed",
    "Uniform",
    "allocate",
    "as_points",
    "helmholtz_pair",
    "load_source",
    "maxwell_pair",
    "reachable_field",
    "read_mpem",
    "rotation_about",
    "save_source",
    "source_from_dict",
    "source_markers",
    "source_to_dict",
]
