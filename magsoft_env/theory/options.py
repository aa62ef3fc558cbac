"""What every analytical solve checks and shares: the solver's numerical settings, the problem's checks, the
subdomain edges, the grid limits, and which model (planar or 3D) a problem takes.

The planar solver (:mod:`~magsoft_env.theory.solver`) and the 3D rod solver (:mod:`~magsoft_env.theory.rod_solver`)
both import from here and not from each other, except that :func:`~magsoft_env.theory.solve_path` hands a 3D
problem to the rod solver.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..spec import Beam, Field
from ..spec.loading import check_loading
from ..validate import boolean, choice, in_range, integer, positive
from .collocation import make_grid

#: The analytical models (``model`` of :func:`~magsoft_env.theory.solve_path`).
MODELS = ("auto", "planar", "3d")
#: Most collocation nodes of one grid for the 3D rod (the dense Jacobian is 3 M x 3 M).
MAX_ROD_NODES = 400

@dataclass(frozen=True)
class SolverOptions:
    """Numerical settings of the equilibrium solver.

    Attributes
    ----------
    nodes : int or None
        Chebyshev degree per subdomain; None chooses it and refines automatically.
    max_nodes : int
        Largest degree per subdomain automatic refinement may reach.
    tol : float
        Newton tolerance on the angle update (rad).
    resolution_tol : float
        Accepted size of the trailing Chebyshev coefficients of theta (rad).
    max_domain : float
        Longest subdomain as a fraction of L (long smooth beams get split), in [0.01, 1].
    min_step : float
        Smallest continuation step (fraction of a load segment) before a fold is declared.
    verify_tol : float
        Largest equation residual between the nodes (rad) that a successful result may have
        (:mod:`magsoft_env.theory.verify`); the grid is refined (degree, then subdomains) until it
        holds, and a result that still exceeds it has status 4 and ``success=False``.
    split_at_knots : bool
        Cut subdomains at the knots of cubic-spline profiles when there are at most
        ``MAX_KNOT_EDGES`` of them (the solution's fourth derivative jumps there); False leaves
        them to the refinement (cheaper where the accuracy asked for is modest).
    max_step_work : float
        3D rod only: the most work one load step (from one field to the next, folds and bifurcations
        included) may take, counted in dense solves of a 100-node grid (a Newton iteration on M nodes
        counts (M / 100)^3; a stability test or energy-descent iteration 2-3 times that). Past it the
        path ends with status 5 and a message saying where; math.inf removes the bound. The default,
        15000, is 30-75 s on a 2-core x86_64 machine (2-5 ms a unit measured, the more the busier its
        cores); the test cases take under 50, 300 stress-benchmark cases (fields to 40 mT) under 75,
        and 169 random strips of 8-18 cells with fields to 80-100 mT (folds included) under 10500.

    Ranges (checked by :meth:`check`, which every solve calls before any work): ``nodes`` None
    or an integer in [8, 400]; ``max_nodes`` an integer in [8, 1000]; ``tol`` in [1e-15, 1e-6];
    ``resolution_tol`` in [0, 1e-3]; ``min_step`` in [1e-12, 0.5]; ``verify_tol`` in [1e-14, 1e-2];
    ``max_step_work`` > 0 (math.inf allowed).
    """

    nodes: int | None = None
    max_nodes: int = 160
    tol: float = 1e-12
    resolution_tol: float = 1e-11
    max_domain: float = 1.0
    min_step: float = 1e-5
    verify_tol: float = 1e-8
    split_at_knots: bool = True
    max_step_work: float = 15_000.0

    def check(self) -> SolverOptions:
        """Raise ValueError naming the first option outside its range (see above); returns self."""
        if self.nodes is not None:
            integer("SolverOptions.nodes", self.nodes, 8, 400)
        integer("SolverOptions.max_nodes", self.max_nodes, 8, 1000)
        in_range("SolverOptions.tol", self.tol, 1e-15, 1e-6, unit="rad")
        in_range("SolverOptions.resolution_tol", self.resolution_tol, 0.0, 1e-3, unit="rad")
        in_range("SolverOptions.max_domain", self.max_domain, 0.01, 1.0, unit="fraction of L")
        in_range("SolverOptions.min_step", self.min_step, 1e-12, 0.5, unit="fraction of a load segment")
        in_range("SolverOptions.verify_tol", self.verify_tol, 1e-14, 1e-2, unit="rad")
        boolean("SolverOptions.split_at_knots", self.split_at_knots)
        if self.max_step_work != math.inf:
            positive("SolverOptions.max_step_work", self.max_step_work, unit="dense solves of a 100-node grid")
        return self


#: Largest number of collocation nodes of one grid (subdomains x (degree + 1)): the dense solves
#: cost O(M^3) per Newton iteration (about 0.1 s at 1000 nodes).
MAX_TOTAL_NODES = 1000


#: Spline knots that become subdomain edges (where a cubic spline's third derivative jumps, the
#: solution is only piecewise smooth); denser knot sets (a sampled jig function) are left alone.
MAX_KNOT_EDGES = 64


def subdomain_edges(beam: Beam, knots: bool = True) -> tuple[float, ...]:
    """Interior subdomain edges: the beam's breakpoints, and its spline knots when they are few."""
    knots = beam.spline_knots() if knots else ()
    if not knots or len(knots) > MAX_KNOT_EDGES:
        return beam.breakpoints()
    merged: list[float] = []
    for p in sorted({*beam.breakpoints(), *knots}):
        if not merged or p - merged[-1] > 1e-9 * beam.length:
            merged.append(p)
    return tuple(merged)




def use_rod(beam, fields, model: str) -> bool:
    """Whether a problem takes the 3D rod (see ``model`` in :func:`solve_path`)."""
    model = choice("model", model, MODELS)
    if not isinstance(beam, Beam):
        raise ValueError(f"beam must be a magsoft_env.Beam, got {type(beam).__name__}.")
    if model == "3d":
        return True
    if isinstance(fields, Field) or (_triple(fields)):
        fields = [fields]  # one field given where a sequence is expected: as_fields says so
    if isinstance(fields, np.ndarray):
        three = fields.ndim == 2 and fields.shape[1] == 3
        out_of_plane = three and bool(np.any(fields[:, 1] != 0))
    else:
        try:
            items = list(fields)
        except TypeError:
            items = []
        three = any(_triple(f) for f in items)
        out_of_plane = any((isinstance(f, Field) and not f.is_planar) or (_triple(f) and _nonzero(f[1]))
                           for f in items)
        three = three or out_of_plane
    if model == "planar":
        if out_of_plane:
            raise ValueError("model='planar' bends the beam in the x-z plane: every field must have B_y = 0, "
                             "got a field with a B_y component; use model='3d' (or 'auto').")
        if not beam.is_planar:
            raise ValueError("model='planar' cannot take a magnetization with a component across the width; "
                             "use model='3d' (or 'auto').")
        return False
    return three or not beam.is_planar




def _triple(v) -> bool:
    """Whether ``v`` is one field given by three numbers (not a sequence of three fields)."""
    if isinstance(v, (str, bytes, dict, set, frozenset, Field)):
        return False
    try:
        a = np.asarray(v, dtype=float)
    except (TypeError, ValueError):
        return False
    return a.shape == (3,)




def _nonzero(v) -> bool:
    try:
        return float(v) != 0.0
    except (TypeError, ValueError):
        return False  # as_fields reports it




def check_problem(beam, gravity, support, coupling, extensible, clamp_angle, options, *, rod: bool = False):
    if not isinstance(beam, Beam):
        raise ValueError(f"beam must be a magsoft_env.Beam, got {type(beam).__name__}.")
    lo = check_loading(gravity=gravity, support=support, coupling=coupling, extensible=extensible,
                       clamp_angle=clamp_angle)
    g, support, coupling, th0 = lo["gravity"], lo["support"], lo["coupling"], lo["clamp_angle"]
    if rod and coupling != "rotated":
        raise ValueError(
            "coupling='paper' is planar only: the paper's eq. (10) couples only the axial component "
            "B_r cos(beta) of the magnetization, which has no meaning for a cross-section that turns in 3D. "
            "The 3D rod uses the rotated coupling (A B_r / mu0) (R m_hat) x B; pass coupling='rotated'."
        )
    if rod and lo["extensible"]:
        raise ValueError("extensible=True is planar only: the 3D rod is inextensible (axial strain is about 1 % "
                         "at 13 mT); pass extensible=False.")
    if options is None:
        options = SolverOptions()
    elif not isinstance(options, SolverOptions):
        raise ValueError(f"options must be a SolverOptions, got {options!r}.")
    options.check()
    edges = subdomain_edges(beam, options.split_at_knots)
    d = len(make_grid(beam.length, edges, n=8, max_domain=options.max_domain * beam.length).edges) - 1
    n_max = options.nodes if options.nodes is not None else options.max_nodes
    if rod and d * 9 > MAX_ROD_NODES:
        raise ValueError(
            f"the beam has {d} smooth pieces (breakpoints of its profiles, max_domain): the 3D rod needs at least "
            f"{9 * d} collocation nodes, more than {MAX_ROD_NODES}; use fewer cells or a larger max_domain."
        )
    if d * 9 > MAX_TOTAL_NODES:
        raise ValueError(
            f"the beam has {d} smooth pieces (breakpoints of its profiles, max_domain): at least {9 * d} "
            f"collocation nodes, more than {MAX_TOTAL_NODES}; use fewer cells or a larger max_domain."
        )
    if d * (n_max + 1) > MAX_TOTAL_NODES and options.nodes is not None:
        raise ValueError(
            f"options.nodes = {n_max} on this beam's {d} subdomains gives {d * (n_max + 1)} collocation nodes, "
            f"more than {MAX_TOTAL_NODES} (a Newton iteration would take ~{(d * (n_max + 1) / 1e3) ** 3 * 0.1:.2g} s); "
            "lower nodes or raise max_domain."
        )
    return g, support, coupling, bool(extensible), th0, options


__all__ = ["MAX_KNOT_EDGES", "MAX_ROD_NODES", "MAX_TOTAL_NODES", "MODELS", "SolverOptions", "check_problem",
           "subdomain_edges", "use_rod"]
