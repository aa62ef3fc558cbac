"""A batch of planar rods in MuJoCo Warp: one model put once, ``nworld`` worlds, per-world fields and resets.

:class:`WarpRodBatch` puts a compiled rod model (:mod:`magsoft_env.sim.model`) on a Warp device with MuJoCo's
auto-reset flag cleared (MJWarp refuses it, and never auto-resets: a world that goes non-finite stays so, which
:meth:`WarpRodBatch.failures` reports), the solver tolerance raised to MJWarp's float32 floor and contact buffers
sized for the rod. :meth:`WarpRodBatch.advance` runs ``k`` substeps of every world under its own held field,
recorded once as a Warp graph (``wp.ScopedCapture``, on the CPU device too) and replayed at every call, or
launched kernel by kernel (``graph=False``: the same numbers, bit for bit). After every substep a small kernel
reduces each world's centreline (the state that substep started from, as MuJoCo's history buffers hold it in C)
to the crawl limits' figures, and another its deepest contact; the end state's kinematics and ``M qvel`` (for
the kinetic energy) close the graph. :meth:`WarpRodBatch.advance_waveforms` plays one period of a per-world
waveform instead, the phase from a per-world step counter (MJWarp's ``d.time`` is float32), in graphs of
``block`` substeps replayed until the longest period ends; a world whose period is over keeps its end state. The
energy balance of :mod:`magsoft_env.sim.health` (runaway kinetic energy, energy drift) is kept per world on the
device, and :meth:`WarpRodBatch.failures` turns every world's records into the error the C simulator would raise
(:mod:`magsoft_env.sim.health`'s builders). The rod's readouts (centreline, angles, rates, centre of mass,
orientation) are computed per world from a :meth:`WarpRodBatch.state`. Worlds are reset by mask from states the
caller computes in C (:meth:`WarpRodBatch.reset_worlds`).
Friction (the rod-floor contact pairs) and a field scale may differ per world (MJWarp's batched model arrays).
"""

from __future__ import annotations

import copy
import math

import mujoco
import numpy as np

from ..fields.base import MU0_4PI
from . import magnetics
from .health import (
    ENERGY_DRIFT_LIMIT,
    PENETRATION_HINT,
    RUNAWAY_FACTOR,
    STABILITY_HINT,
    TUNNELLING_HINT,
    SimulationError,
    launch_reason,
    nonfinite_error,
    penetration_figures,
    penetration_reason,
    runaway_error,
    setting_text,
    tunnelling_figures,
    tunnelling_reason,
    unphysical_error,
    unstable_error,
)
from .model import contact_timeconst, field_controls
from .warp_extra import require_warp
from .warp_sources import _source_energy, _source_loads, dipole_arrays

wp, mjw = require_warp()

#: MJWarp's float32 solver stops at this tolerance at best (the C rods use 1e-8).
TOLERANCE_FLOOR = 1e-6
#: Overflow bits that mean a world's contacts or constraints did not fit its buffers (the solver's iteration
#: caps, which C also hits silently, are not failures).
BUFFER_OVERFLOWS = int(mjw.OverflowType.NEFC | mjw.OverflowType.NJMAX_NNZ | mjw.OverflowType.BROADPHASE
                       | mjw.OverflowType.NARROWPHASE | mjw.OverflowType.CCD | mjw.OverflowType.CONTACT_MATCH
                       | mjw.OverflowType.NVMAX)
#: What to change when a world's contacts or constraint rows did not fit MJWarp's buffers.
OVERFLOW_HINT = "The contacts or constraint rows did not fit MJWarp's buffers: raise nconmax / njmax"


@wp.kernel
def _write_inputs(mag: wp.array[float], quat: wp.array2d[float], mocap: int, ctrl: wp.array2d[float],
                  mocap_quat: wp.array2d[wp.quat]):
    w, u = wp.tid()
    ctrl[w, u] = mag[w]
    if u == 0:
        mocap_quat[w, mocap] = wp.quat(quat[w, 0], quat[w, 1], quat[w, 2], quat[w, 3])  # MuJoCo's order, w first


@wp.kernel
def _clear_records(clear_max: wp.array[float], cos_min: wp.array[float], airborne: wp.array[int],
                   violation: wp.array[int], figures: wp.array2d[float], depth: wp.array[float],
                   depth_best: wp.array[float], depth_at: wp.array[int]):
    w = wp.tid()
    clear_max[w] = -1.0e30
    cos_min[w] = 1.0e30
    airborne[w] = 0
    violation[w] = -1
    figures[w, 0] = 0.0
    figures[w, 1] = 0.0
    figures[w, 2] = 0.0
    depth[w] = -1.0e30
    depth_best[w] = -1.0e30
    depth_at[w] = -1


@wp.kernel
def _limits(xpos: wp.array2d[wp.vec3], xmat: wp.array2d[wp.mat33], bodies: wp.array[int],
            inv_len: wp.array[float], tip_len: float, half_h: float, max_clearance: float, cos_rotation: float,
            max_height: float, mode: int, airborne_tol: float, column: int, count: int, step: wp.array[int],
            nsub: wp.array[int], clear_max: wp.array[float], cos_min: wp.array[float], airborne: wp.array[int],
            violation: wp.array[int], figures: wp.array2d[float], pen_limit: float, depth: wp.array[float],
            depth_best: wp.array[float], depth_at: wp.array[int]):
    """One column of the crawl limits of every world: clearance of the lowest centreline point, the highest point
    and the cos of the largest piece angle; the first column that breaks a limit is kept with its figures
    (the device twin of :mod:`magsoft_env.envs.crawl_task`'s ``crawl_limits``, ``limit_summary`` and
    ``first_violation``). ``mode``: 0 none, 1 rotation, 2 height. The column is ``column + step[w]`` (``column``
    -2: the end state); a world whose ``step`` has reached its ``nsub`` (its period is over) is left out. A substep
    column (``count`` 1) whose deepest contact (``depth``, the running maximum of :func:`_deepest`) is the deepest
    yet is kept in ``depth_best`` and ``depth_at``, until one is deeper than ``pen_limit``: as the C simulator's
    check, which stops at the first step that breaks the bound."""
    w = wp.tid()
    if column != -2 and step[w] >= nsub[w]:
        return
    col = column
    if column != -2:
        col = column + step[w]
    if count != 0 and depth_best[w] <= pen_limit and depth[w] > depth_best[w]:
        depth_best[w] = depth[w]
        depth_at[w] = col
    n = bodies.shape[0]
    # float(): variables a Warp loop changes are declared dynamic
    lo = float(1.0e30)  # noqa: UP018
    hi = float(-1.0e30)  # noqa: UP018
    cmin = float(1.0e30)  # noqa: UP018
    px = float(0.0)  # noqa: UP018
    for i in range(n + 1):
        if i < n:
            p = xpos[w, bodies[i]]
            x = p[0]
            z = p[2]
        else:
            b = bodies[n - 1]
            p = xpos[w, b]
            r = xmat[w, b]
            x = p[0] + tip_len * r[0, 0]
            z = p[2] + tip_len * r[2, 0]
        lo = wp.min(lo, z)
        hi = wp.max(hi, z)
        if i > 0:
            cmin = wp.min(cmin, (x - px) * inv_len[i - 1])
        px = x
    clear = lo - half_h
    clear_max[w] = wp.max(clear_max[w], clear)
    cos_min[w] = wp.min(cos_min[w], cmin)
    if count != 0 and clear > airborne_tol:
        airborne[w] = airborne[w] + 1
    if mode != 0 and violation[w] < 0:
        broken = clear > max_clearance
        if mode == 1:
            broken = broken or cmin < cos_rotation
        else:
            broken = broken or hi > max_height
        if broken:
            violation[w] = col
            figures[w, 0] = clear
            figures[w, 1] = hi
            figures[w, 2] = cmin


@wp.kernel
def _deepest(nacon: wp.array[int], dist: wp.array[float], worldid: wp.array[int], step: wp.array[int],
             nsub: wp.array[int], depth: wp.array[float]):
    c = wp.tid()
    if c < nacon[0]:
        w = worldid[c]
        if step[w] < nsub[w]:
            wp.atomic_max(depth, w, -dist[c])


@wp.func
def _net_moment(xmat: wp.array2d[wp.mat33], w: int, b0: int, mx: wp.array[wp.float64],
                mz: wp.array[wp.float64]) -> wp.vec2d:
    """Net magnetic moment (world x, z; A m^2) of world ``w``'s pieces at the orientations in ``xmat``."""
    mox = wp.float64(0.0)
    moz = wp.float64(0.0)
    for i in range(mx.shape[0]):
        r = xmat[w, b0 + i]
        mox += wp.float64(r[0, 0]) * mx[i] + wp.float64(r[0, 2]) * mz[i]
        moz += wp.float64(r[2, 0]) * mx[i] + wp.float64(r[2, 2]) * mz[i]
    return wp.vec2d(mox, moz)


@wp.kernel
def _book_work(field: wp.array2d[wp.float64], step: wp.array[int], nsub: wp.array[int], xmat: wp.array2d[wp.mat33],
               b0: int, mx: wp.array[wp.float64], mz: wp.array[wp.float64], applied: wp.array2d[wp.float64],
               work: wp.array[wp.float64]):
    """The field's work on every world whose period runs: ``-M . dB``, ``M`` the net moment of the state the
    substep started from (``xmat`` after ``mjw.step``), ``dB`` the change from the field the last substep applied."""
    w = wp.tid()
    if step[w] >= nsub[w]:
        return
    db0 = field[w, 0] - applied[w, 0]
    db1 = field[w, 1] - applied[w, 1]
    if db0 != wp.float64(0.0) or db1 != wp.float64(0.0):
        mom = _net_moment(xmat, w, b0, mx, mz)
        work[w] = work[w] - (mom[0] * db0 + mom[1] * db1)
    applied[w, 0] = field[w, 0]
    applied[w, 1] = field[w, 1]


@wp.kernel
def _energy(qpos: wp.array2d[float], qvel: wp.array2d[float], mqvel: wp.array2d[float], xipos: wp.array2d[wp.vec3],
            xmat: wp.array2d[wp.mat33], hq: wp.array[int], hd: wp.array[int], stiffness: wp.array[wp.float64],
            mass_g: wp.array[wp.float64], b0: int, mx: wp.array[wp.float64], mz: wp.array[wp.float64],
            applied: wp.array2d[wp.float64], dt: wp.float64, staggered: int, rebase: int, mask: wp.array[int],
            step: wp.array[int], nsub: wp.array[int], scale: wp.array[wp.float64], e0: wp.array[wp.float64],
            work: wp.array[wp.float64], ke_max: wp.array[wp.float64], drift_max: wp.array[wp.float64],
            sourced: int, source_e: wp.array[wp.float64]):
    """Every world's energy (kinetic + elastic + gravitational + magnetic, J) under the field it applied last.

    ``rebase``: the worlds of ``mask`` start their balance here (``e0``, the work and the records zeroed);
    else the worlds whose period covered the whole block (``step <= nsub``) record their largest kinetic energy
    and energy drift ``(E - e0 - work) / scale``. ``staggered``: positions of the last substep's start paired
    with the new velocities (after ``mjw.step``), the hinge angles then ``qpos - dt qvel``. ``sourced``: add the
    energy in the dipole sources, ``source_e`` (:func:`~magsoft_env.sim.warp_sources._source_energy`)."""
    w = wp.tid()
    if rebase != 0:
        if mask[w] == 0:
            return
    elif step[w] > nsub[w]:
        return
    ke = wp.float64(0.0)
    for i in range(qvel.shape[1]):
        ke += wp.float64(qvel[w, i]) * wp.float64(mqvel[w, i])
    ke = wp.float64(0.5) * ke
    el = wp.float64(0.0)
    for i in range(hq.shape[0]):
        q = wp.float64(qpos[w, hq[i]])
        if staggered != 0:
            q = q - dt * wp.float64(qvel[w, hd[i]])
        el += stiffness[i] * q * q
    gr = wp.float64(0.0)
    for i in range(mass_g.shape[0]):
        gr += mass_g[i] * wp.float64(xipos[w, b0 + i][2])
    mom = _net_moment(xmat, w, b0, mx, mz)
    e = ke + wp.float64(0.5) * el + gr - (mom[0] * applied[w, 0] + mom[1] * applied[w, 1])
    if sourced != 0:
        e = e + source_e[w]
    if rebase != 0:
        e0[w] = e
        work[w] = wp.float64(0.0)
        ke_max[w] = wp.float64(0.0)
        drift_max[w] = wp.float64(0.0)
        return
    ratio = ke / scale[w]
    drift = (e - e0[w] - work[w]) / scale[w]
    if not (ratio <= ke_max[w]):  # NaN is kept: a non-finite energy is a runaway
        ke_max[w] = ratio
    if not (drift <= drift_max[w]):
        drift_max[w] = drift


@wp.kernel
def _clear_energy_records(ke_max: wp.array[wp.float64], drift_max: wp.array[wp.float64]):
    w = wp.tid()
    ke_max[w] = wp.float64(0.0)
    drift_max[w] = wp.float64(-1.0e300)


@wp.kernel
def _wave_inputs(step: wp.array[int], nsub: wp.array[int], wave: wp.array2d[wp.float64], dt: wp.float64,
                 mocap: int, field: wp.array2d[wp.float64], ctrl: wp.array2d[float],
                 mocap_quat: wp.array2d[wp.quat]):
    """The field of every world's present substep of its period, ``B_x = A_x sin(2 pi f t + phase)``,
    ``B_z = A_z sin(2 pi f t)`` at ``t = step dt`` (float64, from the step counter), as the actuators' ``|B|`` and
    the field frame's quaternion (:func:`~magsoft_env.sim.model.field_controls`' arithmetic); a world past its
    period holds its last substep's field. ``wave`` rows: ``A_x, A_z, f, phase`` (T, T, Hz, rad)."""
    w = wp.tid()
    j = wp.min(step[w], nsub[w] - 1)
    t = wp.float64(j) * dt
    ph = wp.float64(2.0 * 3.141592653589793) * wave[w, 2] * t
    bx = wave[w, 0] * wp.sin(ph + wave[w, 3])
    bz = wave[w, 1] * wp.sin(ph)
    field[w, 0] = bx
    field[w, 1] = bz
    mag = wp.sqrt(bx * bx + bz * bz)
    c = mag + bx
    s = bz
    if bx < wp.float64(0.0):
        c = bz
        s = mag - bx
    norm = wp.sqrt(c * c + s * s)
    qw = wp.float64(1.0)
    qy = wp.float64(0.0)
    if norm != wp.float64(0.0):
        qw = c / norm
        qy = -(s / norm)
    for u in range(ctrl.shape[1]):
        ctrl[w, u] = float(mag)
    if mocap >= 0:
        mocap_quat[w, mocap] = wp.quat(float(qw), 0.0, float(qy), 0.0)


@wp.kernel
def _tick(step: wp.array[int], nsub: wp.array[int], qpos: wp.array2d[float], qvel: wp.array2d[float],
          warm: wp.array2d[float], time: wp.array[float], overflow: wp.array[int], qpos_end: wp.array2d[float],
          qvel_end: wp.array2d[float], warm_end: wp.array2d[float], time_end: wp.array[float],
          overflow_end: wp.array[int]):
    """After a substep: a world whose period has just ended keeps its state (restored by :func:`_restore` after
    the block in which the longest period ends); the step counter moves on."""
    w = wp.tid()
    j = step[w]
    if j + 1 == nsub[w]:
        for i in range(qpos.shape[1]):
            qpos_end[w, i] = qpos[w, i]
        for i in range(qvel.shape[1]):
            qvel_end[w, i] = qvel[w, i]
            warm_end[w, i] = warm[w, i]
        time_end[w] = time[w]
        overflow_end[w] = overflow[w]
    step[w] = j + 1


@wp.kernel
def _restore(qpos: wp.array2d[float], qvel: wp.array2d[float], warm: wp.array2d[float], time: wp.array[float],
             overflow: wp.array[int], qpos_end: wp.array2d[float], qvel_end: wp.array2d[float],
             warm_end: wp.array2d[float], time_end: wp.array[float], overflow_end: wp.array[int]):
    w = wp.tid()
    for i in range(qpos.shape[1]):
        qpos[w, i] = qpos_end[w, i]
    for i in range(qvel.shape[1]):
        qvel[w, i] = qvel_end[w, i]
        warm[w, i] = warm_end[w, i]
    time[w] = time_end[w]
    overflow[w] = overflow_end[w]


@wp.kernel
def _set_int(a: wp.array[int], value: int):
    a[wp.tid()] = value


@wp.kernel
def _reset_masked(mask: wp.array[int], qpos_new: wp.array2d[float], qvel_new: wp.array2d[float],
                  qpos: wp.array2d[float], qvel: wp.array2d[float], qacc_warmstart: wp.array2d[float],
                  time: wp.array[float], overflow: wp.array[int], applied: wp.array2d[wp.float64]):
    w = wp.tid()
    if mask[w] == 0:
        return
    applied[w, 0] = wp.float64(0.0)
    applied[w, 1] = wp.float64(0.0)
    for i in range(qpos.shape[1]):
        qpos[w, i] = qpos_new[w, i]
    for i in range(qvel.shape[1]):
        qvel[w, i] = qvel_new[w, i]
        qacc_warmstart[w, i] = 0.0
    time[w] = 0.0
    overflow[w] = 0


def warp_model_source(model: mujoco.MjModel) -> mujoco.MjModel:
    """A copy of ``model`` that MJWarp accepts: auto-reset cleared (MJWarp refuses the flag; the batch does its own
    health checks), the solver tolerance at least :data:`TOLERANCE_FLOOR`, no noslip iterations."""
    src = copy.copy(model)
    src.opt.disableflags &= ~int(mujoco.mjtDisableBit.mjDSBL_AUTORESET)
    src.opt.tolerance = max(float(src.opt.tolerance), TOLERANCE_FLOOR)
    src.opt.noslip_iterations = 0
    return src


class WarpRodBatch:
    """``nworld`` copies of a planar rod model (:class:`~magsoft_env.sim.model.RodModel`) in MuJoCo Warp.

    Parameters
    ----------
    rod : RodModel
        The compiled rod (a :class:`~magsoft_env.sim.Simulator`'s ``rod``).
    data : mujoco.MjData
        The state every world starts from (settled in C: float32 Warp and float64 C disagree on contacts at
        exactly zero distance).
    nworld : int
        Worlds.
    limits : dict, optional
        The crawl limits the substep kernel holds: ``half_thickness`` (m), ``inv_piece_length`` (1/m, one per
        piece), ``max_clearance`` (m, inf: none), ``cos_rotation``, ``max_height`` (m), ``mode`` (0 none,
        1 rotation, 2 height), ``airborne_tolerance`` (m), ``penetration_limit`` (m: the deepest contact is
        followed up to the first substep deeper than it, as the C simulator's check; default inf).
    device : str, optional
        Warp device (None: Warp's default, a GPU where there is one).
    graph : bool
        Record :meth:`advance` as a graph and replay it (False: launch the kernels each call).
    nconmax, njmax : int, optional
        Contacts and constraint rows per world (None: sized for the rod lying flat, with room to spare).
    backend : PlanarRod, optional
        The C simulator's rod backend (``Simulator.backend``): with it the energy balance is kept per world
        (:meth:`energy_records`).
    friction : array_like, optional
        Sliding friction of the rod-floor contact pairs per world, shape ``(nworld,)`` (None: the model's). The
        pairs' torsional and rolling friction stay the model's.
    field_scale : array_like, optional
        Factor on every world's applied field, shape ``(nworld,)`` (None: 1).
    block : int
        Substeps per graph of :meth:`advance_waveforms` (and between its energy checks).
    """

    def __init__(self, rod, data: mujoco.MjData, nworld: int, *, limits: dict | None = None, device=None,
                 graph: bool = True, nconmax: int | None = None, njmax: int | None = None, backend=None,
                 friction=None, field_scale=None, block: int = 100):
        self.rod = rod
        self.nworld = int(nworld)
        self.device = wp.get_device(device)
        src = warp_model_source(rod.model)
        self.source = src
        ngeom = int(src.ngeom)
        self.nconmax = int(nconmax) if nconmax is not None else 4 * ngeom + 16
        rows = 6 if src.opt.cone == mujoco.mjtCone.mjCONE_PYRAMIDAL else 3
        self.njmax = int(njmax) if njmax is not None else rows * self.nconmax + int(src.nv)
        self.block = int(block)
        n = self.nworld
        self.friction = None if friction is None else self._per_world("friction", friction, lo=0.0)
        self.field_scale = np.ones(n) if field_scale is None else self._per_world("field_scale", field_scale)
        if self.friction is not None and src.npair == 0:
            raise ValueError("friction per world needs the rod's contact pairs (a floor scene); this model has none.")
        with wp.ScopedDevice(self.device):
            batch = {"pair_friction": n} if self.friction is not None else None
            self.m = mjw.put_model(src, batch_sizes=batch)
            if self.friction is not None:
                pf = np.tile(np.asarray(src.pair_friction, dtype=np.float32), (n, 1, 1))
                pf[:, :, 0] = pf[:, :, 1] = self.friction[:, None]
                self.m.pair_friction.assign(pf)
            self.m.opt.warn_overflow = 0  # recorded per world in d.overflow, read by failures()
            self.m.opt.contact_sensor_maxmatch = max(int(self.m.opt.contact_sensor_maxmatch), self.nconmax)
            self.d = mjw.put_data(src, data, nworld=n, nconmax=self.nconmax, njmax=self.njmax)
            nq, nv = int(src.nq), int(src.nv)
            self._mag = wp.zeros(n, dtype=float)
            self._quat = wp.array(np.tile([1.0, 0.0, -0.0, 0.0], (n, 1)), dtype=float)
            self.clear_max = wp.zeros(n, dtype=float)
            self.cos_min = wp.zeros(n, dtype=float)
            self.airborne = wp.zeros(n, dtype=int)
            self.violation = wp.zeros(n, dtype=int)
            self.figures = wp.zeros((n, 3), dtype=float)
            self.depth = wp.zeros(n, dtype=float)
            self._depth_best = wp.zeros(n, dtype=float)
            self.depth_at = wp.zeros(n, dtype=int)
            self.mqvel = wp.zeros((n, nv), dtype=float)
            self._mask = wp.zeros(n, dtype=int)
            self._qpos_new = wp.zeros((n, nq), dtype=float)
            self._qvel_new = wp.zeros((n, nv), dtype=float)
            self._bodies = wp.array(np.asarray(rod.body_ids, dtype=np.int32), dtype=int)
            # the substep counter of a waveform period and the periods' lengths (field mode: 0 and "never ends")
            self._zero = wp.zeros(n, dtype=int)
            self._never = wp.full(n, 2**30, dtype=int)
            self._step = wp.zeros(n, dtype=int)
            self._nsub = wp.zeros(n, dtype=int)
            self._wave = wp.zeros((n, 4), dtype=wp.float64)
            self._qpos_end = wp.zeros((n, nq), dtype=float)
            self._qvel_end = wp.zeros((n, nv), dtype=float)
            self._warm_end = wp.zeros((n, nv), dtype=float)
            self._time_end = wp.zeros(n, dtype=float)
            self._overflow_end = wp.zeros(n, dtype=int)
            # the energy balance (float64): the field applied last, its work, the start energy, the records
            self._field = wp.zeros((n, 2), dtype=wp.float64)
            self._applied = wp.zeros((n, 2), dtype=wp.float64)
            self._work = wp.zeros(n, dtype=wp.float64)
            self._e0 = wp.zeros(n, dtype=wp.float64)
            self._scale = wp.ones(n, dtype=wp.float64)
            self.ke_max = wp.zeros(n, dtype=wp.float64)
            self.drift_max = wp.zeros(n, dtype=wp.float64)
            # field sources (set_sources): the pieces' body moments (A m^2) and half lengths (m), body-id order
            # (float32), the dipoles per world (None: no source) and their energy per world (J)
            order = np.argsort(np.asarray(rod.body_ids))
            mb = magnetics.body_moments_3d(rod.disc.moment)[order]
            self._src_b0 = int(np.min(rod.body_ids))
            self._src_mx = wp.array(mb[:, 0].astype(np.float32), dtype=float)
            self._src_mz = wp.array(mb[:, 2].astype(np.float32), dtype=float)
            self._src_half = wp.array((0.5 * np.asarray(rod.disc.piece_length, dtype=float)[order]).astype(np.float32),
                                      dtype=float)
            self._spos = self._smom = None
            self._src_energy = wp.zeros(n, dtype=wp.float64)
            self._armed = False
            # the batch writes no external wrench: loads the start state carried (a source's in C) are not held
            self.d.xfrc_applied.zero_()
            disc = rod.disc
            lim = dict(limits or {})
            #: the rod's pieces' lengths (m): the backend's pose's (the crawl env's) where there is one
            self.piece_lengths = (np.diff(backend.arc_length()) if backend is not None
                                  else np.asarray(disc.piece_length, dtype=float))
            inv = lim.get("inv_piece_length", 1.0 / self.piece_lengths)
            self._inv_len = wp.array(np.asarray(inv, dtype=np.float32).ravel(), dtype=float)
            self.backend = backend
            if backend is not None:
                hq = np.arange(nq)[backend._hq] if isinstance(backend._hq, slice) else np.asarray(backend._hq)
                hd = np.arange(nv)[backend._hd] if isinstance(backend._hd, slice) else np.asarray(backend._hd)
                self._hq = wp.array(hq.astype(np.int32), dtype=int)
                self._hd = wp.array(hd.astype(np.int32), dtype=int)
                self._hinge_k = wp.array(np.asarray(backend._hinge_k, dtype=float), dtype=wp.float64)
                self._mass_g = wp.array(np.asarray(backend._mass_g_ids, dtype=float), dtype=wp.float64)
                self._mx = wp.array(np.asarray(backend._mx, dtype=float), dtype=wp.float64)
                self._mz = wp.array(np.asarray(backend._mz, dtype=float), dtype=wp.float64)
                self._b0 = int(backend.b0)
        self._tip_len = float(disc.piece_length[-1])
        self._half_h = float(lim.get("half_thickness", 0.0))
        self._max_clearance = float(lim.get("max_clearance", math.inf))
        self._cos_rotation = float(lim.get("cos_rotation", -2.0))
        self._max_height = float(lim.get("max_height", math.inf))
        self._mode = int(lim.get("mode", 0))
        self._airborne_tol = float(lim.get("airborne_tolerance", math.inf))
        self._pen_limit = float(lim.get("penetration_limit", math.inf))
        self._mocap = int(rod.field_mocap) if getattr(rod, "field_mocap", -1) is not None else -1
        self._dt = float(src.opt.timestep)
        self.graph = bool(graph)
        self._graphs: dict[object, object] = {}
        self._periods = np.zeros(n, dtype=np.int64)

    def _per_world(self, name: str, values, *, lo: float | None = None) -> np.ndarray:
        v = np.asarray(values, dtype=float)
        if v.ndim == 0:
            v = np.full(self.nworld, float(v))
        if v.shape != (self.nworld,) or not np.all(np.isfinite(v)) or (np.any(v < lo) if lo is not None
                                                                      else np.any(v <= 0.0)):
            bound = f">= {lo:g}" if lo is not None else "> 0"
            raise ValueError(f"{name} must be one finite number {bound} or one per world (shape ({self.nworld},)), "
                             f"got {values!r}.")
        return v

    # ------------------------------------------------------------------ inputs and the step
    def set_fields(self, fields: np.ndarray) -> None:
        """Hold the fields ``(nworld, 2)`` (B_x, B_z; T), one per world, from the next :meth:`advance` on (times
        the world's ``field_scale``)."""
        f = np.asarray(fields, dtype=float).reshape(self.nworld, 2) * self.field_scale[:, None]
        mag, quat = field_controls(f)
        self._mag.assign(mag.astype(np.float32))
        self._quat.assign(quat.astype(np.float32))
        self._field.assign(f)

    def set_energy_scale(self, scale: np.ndarray) -> None:
        """The energy scale (J) of every world's present step (:meth:`PlanarRod.energy_scale
        <magsoft_env.sim.planar.PlanarRod.energy_scale>` of its field), for the runaway and drift records."""
        self._scale.assign(np.asarray(scale, dtype=float).reshape(self.nworld))

    # ------------------------------------------------------------------ field sources (point dipoles per world)
    def set_sources(self, positions, moments, *, scale: float = MU0_4PI) -> None:
        """Apply point dipoles per world besides the held field, from the next :meth:`advance` on.

        ``positions`` (m) and ``moments`` (A m^2 with the default ``scale`` mu0/(4 pi); ``scale=1``: moments with
        mu0/(4 pi) folded in, T m^3, the MPEM ``B_Coeff`` convention), each of shape ``(nworld, K, 3)`` (or
        ``(K, 3)``: the same dipoles in every world). A dipole whose moment is zero is none: a world with fewer
        than ``K`` dipoles pads its rows with zero moments, a world with all zero has no source.
        :func:`~magsoft_env.sim.warp_sources.dipole_arrays` makes these arrays (``scale=1``) from sources
        (``PointDipole``, ``DipoleSet``, ``CoilSystem.at_currents(I)``, a magnet at a pose, ...):
        :meth:`set_field_sources`.

        Every substep, after MJWarp's kinematics of the state it starts from (the ``control`` callback of
        ``mjw.step``: no extra kinematics), a kernel sums each world's dipoles' field and gradient at its pieces'
        midpoints and writes the couples ``m x B`` and forces ``G^T m`` into ``xfrc_applied`` (in the x-z plane, with
        the moment arm to each body's centre of mass), as the C simulator's ``source=`` does before every step. The
        energy records count the dipoles' energy ``-sum m . B``. ``field_scale`` does not scale the dipoles. The
        field at the pieces is not checked during the steps (C refuses more than 1 T in a component at any step):
        keep the pieces off the dipoles.
        """
        pos = np.asarray(positions, dtype=float)
        mom = np.asarray(moments, dtype=float)
        n = self.nworld
        want = f"(nworld, K, 3) = ({n}, K, 3) or (K, 3), K >= 1"
        if pos.ndim == 2:
            pos = np.broadcast_to(pos, (n, *pos.shape))
        if mom.ndim == 2:
            mom = np.broadcast_to(mom, (n, *mom.shape))
        if pos.ndim != 3 or pos.shape[0] != n or pos.shape[2] != 3 or pos.shape[1] < 1:
            raise ValueError(f"set_sources positions must have shape {want} (m), got {np.shape(positions)}.")
        if mom.shape != pos.shape:
            raise ValueError(f"set_sources moments must have the shape of positions {pos.shape} (A m^2), got "
                             f"{np.shape(moments)}.")
        if not (np.isfinite(pos).all() and np.isfinite(mom).all()):
            raise ValueError("set_sources positions and moments must be finite.")
        scale = float(scale)
        if not (math.isfinite(scale) and scale > 0.0):
            raise ValueError(f"set_sources scale must be a finite number > 0, got {scale!r}.")
        if self.m.opt.disableflags & mjw.DisableBit.ACTUATION:
            raise ValueError("set_sources needs MJWarp's control callback, which a model with actuation disabled "
                             "never calls.")
        pos32 = pos.astype(np.float32)
        mom32 = (scale * mom).astype(np.float32)
        with wp.ScopedDevice(self.device):
            if self._spos is None or tuple(self._spos.shape) != pos.shape[:2]:
                self._drop_source_graphs()
                self._spos = wp.array(pos32, dtype=wp.vec3)
                self._smom = wp.array(mom32, dtype=wp.vec3)
            else:  # the same arrays: the recorded graphs stay valid
                self._spos.assign(pos32)
                self._smom.assign(mom32)
        self.m.callback.control = self._source_callback

    def set_field_sources(self, sources) -> None:
        """:meth:`set_sources` from one source per world (a sequence of ``nworld``; None: none in that world), each
        a point-dipole source :func:`~magsoft_env.sim.warp_sources.source_dipoles` takes."""
        sources = list(sources)
        if len(sources) != self.nworld:
            raise ValueError(f"set_field_sources takes one source (or None) per world ({self.nworld}), got "
                             f"{len(sources)}.")
        pos, mom = dipole_arrays(sources)
        self.set_sources(pos, mom, scale=1.0)

    def clear_sources(self) -> None:
        """No dipoles from now on: the held field alone, the plain path again (no source kernel, its graphs)."""
        self.m.callback.control = None
        self._spos = self._smom = None
        self._drop_source_graphs()
        with wp.ScopedDevice(self.device):
            self.d.xfrc_applied.zero_()

    def source_dipoles(self) -> tuple[np.ndarray, np.ndarray] | None:
        """The dipoles held, ``(positions m, moments T m^3)`` each ``(nworld, K, 3)`` (float32 values), or None."""
        if self._spos is None:
            return None
        return self._spos.numpy().astype(float), self._smom.numpy().astype(float)

    def write_source_loads(self) -> np.ndarray:
        """Compute the dipoles' loads at the present positions (``xpos`` / ``xmat`` / ``xipos``) into
        ``xfrc_applied`` and return a host copy of its rod rows, ``(nworld, pieces, 6)`` (force N at the CoM, then
        torque N m; chain order), as a substep writes them (a check of the kernel)."""
        if self._spos is None:
            raise ValueError("write_source_loads: no sources (set_sources first).")
        with wp.ScopedDevice(self.device):
            self._armed = True
            self._source_callback(self.m, self.d)
        return self.d.xfrc_applied.numpy()[:, np.asarray(self.rod.body_ids)].astype(float)

    def run_source_kernel(self, k: int = 1) -> None:
        """Launch the dipoles' load kernel ``k`` times at the present positions and wait for the device (what a
        benchmark times: the kernel's own cost per substep)."""
        if self._spos is None:
            raise ValueError("run_source_kernel: no sources (set_sources first).")
        with wp.ScopedDevice(self.device):
            for _ in range(int(k)):
                self._armed = True
                self._source_callback(self.m, self.d)
            wp.synchronize_device(self.device)

    def _drop_source_graphs(self) -> None:
        for key in [k for k in self._graphs if isinstance(k, tuple) and k and k[0] == "sources"]:
            del self._graphs[key]

    def _source_callback(self, m, d) -> None:
        """MJWarp's ``control`` callback (after the kinematics of ``forward``): the source kernel, once a substep
        (RK4 calls ``forward`` at every stage; C's loads are those of the step's start, held over the stages)."""
        if not self._armed:
            return
        self._armed = False
        wp.launch(_source_loads, dim=(self.nworld, self._src_mx.shape[0]), inputs=[
            d.xpos, d.xmat, d.xipos, self._src_b0, self._src_mx, self._src_mz, self._src_half, self._spos,
            self._smom, d.xfrc_applied])

    def _substep(self) -> None:
        """One ``mjw.step`` of every world; with sources, their kernel runs inside it (:meth:`_source_callback`)."""
        self._armed = self._spos is not None
        mjw.step(self.m, self.d)
        self._armed = False

    def _limit_launch(self, column: int, count: int, step=None, nsub=None) -> None:
        wp.launch(_limits, dim=self.nworld, inputs=[
            self.d.xpos, self.d.xmat, self._bodies, self._inv_len, self._tip_len, self._half_h,
            self._max_clearance, self._cos_rotation, self._max_height, self._mode, self._airborne_tol, column,
            count, self._zero if step is None else step, self._never if nsub is None else nsub, self.clear_max,
            self.cos_min, self.airborne, self.violation, self.figures, self._pen_limit, self.depth, self._depth_best,
            self.depth_at])

    def _deepest_launch(self, step, nsub) -> None:
        d = self.d
        wp.launch(_deepest, dim=d.naconmax, inputs=[d.nacon, d.contact.dist, d.contact.worldid, step, nsub,
                                                    self.depth])

    def _work_launch(self, step, nsub) -> None:
        if self.backend is not None:
            wp.launch(_book_work, dim=self.nworld, inputs=[self._field, step, nsub, self.d.xmat, self._b0, self._mx,
                                                           self._mz, self._applied, self._work])

    def _energy_launch(self, *, staggered: bool, rebase: bool, step, nsub) -> None:
        if self.backend is None:
            return
        d = self.d
        mjw.mul_m(self.m, d, self.mqvel, d.qvel)
        sourced = self._spos is not None
        if sourced:  # the dipoles' energy at the positions in xpos / xmat (those the energy below reads)
            wp.launch(_source_energy, dim=self.nworld, inputs=[d.xpos, d.xmat, self._src_b0, self._src_mx,
                                                               self._src_mz, self._src_half, self._spos, self._smom,
                                                               self._src_energy])
        wp.launch(_energy, dim=self.nworld, inputs=[
            d.qpos, d.qvel, self.mqvel, d.xipos, d.xmat, self._hq, self._hd, self._hinge_k, self._mass_g, self._b0,
            self._mx, self._mz, self._applied, self._dt, int(staggered), int(rebase), self._mask, step, nsub,
            self._scale, self._e0, self._work, self.ke_max, self.drift_max, int(sourced), self._src_energy])

    def _clear(self) -> None:
        wp.launch(_clear_records, dim=self.nworld, inputs=[self.clear_max, self.cos_min, self.airborne,
                                                           self.violation, self.figures, self.depth,
                                                           self._depth_best, self.depth_at])
        if self.backend is not None:
            wp.launch(_clear_energy_records, dim=self.nworld, inputs=[self.ke_max, self.drift_max])

    def _launches(self, k: int) -> None:
        m, d, n = self.m, self.d, self.nworld
        if self._mocap >= 0 and m.nu:
            wp.launch(_write_inputs, dim=(n, int(m.nu)), inputs=[self._mag, self._quat, self._mocap, d.ctrl,
                                                                 d.mocap_quat])
        self._clear()
        for j in range(k):
            self._substep()
            # xpos / xmat and the contacts now hold the state this substep started from (MuJoCo's history buffers
            # in C): its deepest contact, then its crawl limits (which keep the substep of the deepest contact)
            self._deepest_launch(self._zero, self._never)
            self._limit_launch(j, 1)
            if j == 0:  # a held field: its work is booked at its jump, with the moment of the state it jumps at
                self._work_launch(self._zero, self._never)
        # the energy check of the step's end, staggered as C's (positions of the last substep's start)
        self._energy_launch(staggered=True, rebase=False, step=self._zero, nsub=self._never)
        self._close()

    def _close(self) -> None:
        mjw.kinematics(self.m, self.d)  # the end state's positions (readouts), as the C simulator's sync
        mjw.mul_m(self.m, self.d, self.mqvel, self.d.qvel)
        self._limit_launch(-2, 0)  # column -2: the end state (the caller names its time)

    def _run(self, key, launches) -> None:
        """``launches()`` as a graph recorded at the first call under ``key`` and replayed after (or plainly)."""
        if not self.graph:
            launches()
            return
        if self._spos is not None:  # a graph with the source kernel (and its arrays) is another graph
            key = ("sources", key)
        g = self._graphs.get(key)
        if g is None:
            with wp.ScopedCapture() as capture:
                launches()
            g = self._graphs[key] = capture.graph
        wp.capture_launch(g)

    def advance(self, k: int) -> None:
        """``k`` substeps of every world under its held field; afterwards the records (:attr:`clear_max`,
        :attr:`cos_min`, :attr:`airborne`, :attr:`violation` with :attr:`figures`, :attr:`depth`) cover the
        ``k`` substeps' start states and the end state, whose positions (``xpos``, ``xmat``, ``xipos``) are
        computed. A graph per ``k``, recorded at its first call."""
        k = int(k)
        with wp.ScopedDevice(self.device):
            self._run(k, lambda: self._launches(k))

    # ------------------------------------------------------------------ waveform periods
    def set_waveforms(self, waves: np.ndarray, nsub: np.ndarray) -> None:
        """Every world's next period: rows ``(A_x, A_z, f, phase)`` (T, T, Hz, rad) of ``B_x = A_x sin(2 pi f t +
        phase)``, ``B_z = A_z sin(2 pi f t)`` (the amplitudes times the world's ``field_scale``) and its length in
        substeps ``nsub`` (``>= 1``)."""
        w = np.array(waves, dtype=float).reshape(self.nworld, 4)
        w[:, :2] *= self.field_scale[:, None]
        nsub = np.asarray(nsub, dtype=np.int64).reshape(self.nworld)
        if nsub.min() < 1:
            raise ValueError(f"nsub must be >= 1 substep per world, got {nsub.min()}.")
        self._wave.assign(w)
        self._nsub.assign(nsub.astype(np.int32))
        self._periods = nsub

    def _wave_start(self) -> None:
        wp.launch(_set_int, dim=self.nworld, inputs=[self._step, 0])
        self._clear()

    def _wave_block(self) -> None:
        d, n = self.d, self.nworld
        step, nsub = self._step, self._nsub
        for _ in range(self.block):
            wp.launch(_wave_inputs, dim=n, inputs=[step, nsub, self._wave, self._dt, self._mocap, self._field,
                                                   d.ctrl, d.mocap_quat])
            self._substep()
            self._deepest_launch(step, nsub)
            self._limit_launch(0, 1, step, nsub)
            self._work_launch(step, nsub)
            wp.launch(_tick, dim=n, inputs=[step, nsub, d.qpos, d.qvel, d.qacc_warmstart, d.time, d.overflow,
                                            self._qpos_end, self._qvel_end, self._warm_end, self._time_end,
                                            self._overflow_end])
        # the worlds whose period covered the whole block: the energy check, staggered as C's
        self._energy_launch(staggered=True, rebase=False, step=step, nsub=nsub)

    def _wave_end(self) -> None:
        d = self.d
        wp.launch(_restore, dim=self.nworld, inputs=[d.qpos, d.qvel, d.qacc_warmstart, d.time, d.overflow,
                                                     self._qpos_end, self._qvel_end, self._warm_end, self._time_end,
                                                     self._overflow_end])
        mjw.kinematics(self.m, d)
        mjw.com_pos(self.m, d)
        mjw.crb(self.m, d)  # the end state's mass matrix (a world that ended early ran on past its end)
        # the end state's energy check (positions and velocities of the end state) for every world
        self._energy_launch(staggered=False, rebase=False, step=self._zero, nsub=self._never)
        self._limit_launch(-2, 0)

    def advance_waveforms(self) -> None:
        """One period of every world's waveform (:meth:`set_waveforms`): ``ceil(max(nsub) / block)`` replays of
        one graph of ``block`` substeps, the field of each from the world's step counter; a world whose period
        ended keeps its end state, to which every world is set afterwards. The records then cover each world's
        ``nsub`` substeps and its end state, as :meth:`advance`'s."""
        blocks = -(-int(self._periods.max()) // self.block)
        with wp.ScopedDevice(self.device):
            self._run("wave_start", self._wave_start)
            for _ in range(blocks):
                self._run("wave_block", self._wave_block)
            self._run("wave_end", self._wave_end)

    # ------------------------------------------------------------------ resets
    def reset_worlds(self, mask: np.ndarray, qpos: np.ndarray, qvel: np.ndarray) -> None:
        """Set the worlds of boolean ``mask`` to ``qpos`` / ``qvel`` rows (``(nworld, nq)``, ``(nworld, nv)``; only
        the masked rows are read), time zero, warm start and overflow flags cleared, the field applied zero and
        the energy balance started again; the others are untouched (their positions are recomputed from the same
        state)."""
        mask = np.asarray(mask, dtype=bool)
        if not mask.any():
            return
        with wp.ScopedDevice(self.device):
            self._mask.assign(mask.astype(np.int32))
            self._qpos_new.assign(np.asarray(qpos, dtype=np.float32))
            self._qvel_new.assign(np.asarray(qvel, dtype=np.float32))
            d = self.d
            wp.launch(_reset_masked, dim=self.nworld, inputs=[self._mask, self._qpos_new, self._qvel_new, d.qpos,
                                                              d.qvel, d.qacc_warmstart, d.time, d.overflow,
                                                              self._applied])
            mjw.kinematics(self.m, d)
            self._energy_launch(staggered=False, rebase=True, step=self._zero, nsub=self._never)
            mjw.mul_m(self.m, d, self.mqvel, d.qvel)

    # ------------------------------------------------------------------ readouts (host copies)
    def state(self) -> dict[str, np.ndarray]:
        """Host copies (float64) of what the env reads: ``qpos``, ``qvel``, ``xpos`` / ``xmat`` / ``xipos`` of
        the rod's bodies (chain order), the substep records, the deepest contact ``depth`` (m; up to the first
        substep deeper than the limits' ``penetration_limit``, as C's check, which stops there) and ``depth_at``,
        the substep whose start state had it (-1: no contact), ``M qvel``, the overflow bits and, with a
        ``backend``, the energy records ``ke_ratio`` (largest kinetic energy over the energy scale at the checks of
        the last call) and ``drift`` (largest energy drift there, in energy scales)."""
        b = np.asarray(self.rod.body_ids)
        d = self.d
        out = {
            "qpos": d.qpos.numpy().astype(float), "qvel": d.qvel.numpy().astype(float),
            "xpos": d.xpos.numpy()[:, b].astype(float), "xmat": d.xmat.numpy()[:, b].astype(float),
            "xipos": d.xipos.numpy()[:, b].astype(float),
            "clear_max": self.clear_max.numpy().astype(float), "cos_min": self.cos_min.numpy().astype(float),
            "airborne": self.airborne.numpy().astype(int), "violation": self.violation.numpy().astype(int),
            "figures": self.figures.numpy().astype(float), "depth": self._depth_best.numpy().astype(float),
            "depth_at": self.depth_at.numpy().astype(int),
            "mqvel": self.mqvel.numpy().astype(float), "overflow": d.overflow.numpy().astype(np.int64),
        }
        if self.backend is not None:
            out["ke_ratio"] = self.ke_max.numpy()
            out["drift"] = self.drift_max.numpy()
        return out

    def qpos(self) -> np.ndarray:
        """Joint positions of every world, ``(nworld, nq)`` (float64 copy)."""
        return self.d.qpos.numpy().astype(float)

    def applied_fields(self) -> np.ndarray:
        """The field every world applied last, ``(nworld, 2)`` (B_x, B_z; T; its ``field_scale`` included)."""
        return self._field.numpy().astype(float)

    # ------------------------------------------------------------------ readouts of a state (the backend's, per world)
    # The C rod backend's readouts (:class:`~magsoft_env.sim.planar.PlanarRod`: pose, angles, rates, orientation)
    # vectorized over the worlds of a :meth:`state`; they need the ``backend``.
    def _chain(self):
        b = self.backend
        if b is None:
            raise ValueError("the readouts of a WarpRodBatch need its backend: WarpRodBatch(..., "
                             "backend=sim.backend).")
        if not hasattr(self, "_omega_map"):
            bodies = np.asarray(self.rod.body_ids)
            self._omega_map = b._angles[0][:, bodies - b.b0]  # (nq = nv, pieces): piece angle about y per qvel
            self._mass = np.asarray(self.rod.disc.mass, dtype=float)
            w = np.diff(b.arc_length())
            self._piece_w, self._piece_total = w, float(w.sum())
            self._base_angle = float(b.options.clamp_angle)
            self._base_qpos = int(self.rod.base_qpos[2]) if self.rod.base_qpos.size else -1
            self._tip_hinges = np.asarray(self.rod.hinge_qpos)[b.options.base_piece:]
        return b

    def centreline(self, s: dict) -> np.ndarray:
        """Every world's centreline (m), ``(nworld, N + 2, 3)``: the base end, every hinge, the tip (the pose's)."""
        self._chain()
        p, R = s["xpos"], s["xmat"].reshape(self.nworld, -1, 9)
        tip = p[:, -1] + self._tip_len * R[:, -1][:, [0, 3, 6]]
        return np.concatenate([p, tip[:, None]], axis=1)

    def angles(self, s: dict) -> np.ndarray:
        """Tangent angle of every world's pieces from +x toward +z (rad), ``(nworld, N + 1)``."""
        R = s["xmat"].reshape(self.nworld, -1, 9)
        return np.arctan2(R[:, :, 6], R[:, :, 0])

    def angular_velocities(self, s: dict) -> np.ndarray:
        """Angular velocity of every world's pieces about -y (rad/s), ``(nworld, N + 1)``."""
        self._chain()
        return -(s["qvel"] @ self._omega_map)

    def com(self, s: dict) -> np.ndarray:
        """Every world's centre of mass (x, z) (m), ``(nworld, 2)``."""
        self._chain()
        p, m = s["xipos"], self._mass
        return np.stack([p[:, :, 0] @ m, p[:, :, 2] @ m], axis=1) / m.sum()

    def orientation(self, s: dict) -> np.ndarray:
        """Every world's orientation end over end (rad), ``(nworld,)``: the length-weighted mean tangent angle of
        its pieces, anchored to the tip's continuous angle (:func:`~magsoft_env.sim.readouts.body_orientation`);
        NaN for a non-finite state."""
        self._chain()
        q, angles = s["qpos"], self.angles(s)
        anchor = self._base_angle + q[:, self._tip_hinges].sum(axis=1)
        if self._base_qpos >= 0:
            anchor = anchor + q[:, self._base_qpos]
        turn = 2.0 * math.pi
        rel = np.cumsum(np.remainder(np.diff(angles, axis=1) + math.pi, turn) - math.pi, axis=1)
        first = angles[:, 0]
        last = first + (rel[:, -1] if rel.shape[1] else 0.0)
        with np.errstate(invalid="ignore"):
            first = first + turn * np.round((anchor - last) / turn)
        out = first + rel @ self._piece_w[1:] / self._piece_total
        return np.where(np.isfinite(anchor), out, np.nan)

    # ------------------------------------------------------------------ health, per world
    def failures(self, s: dict, mask, *, nstep, time, substeps, penetration_limit: float, max_penetration,
                 energy_drift) -> dict[int, SimulationError]:
        """The first failed check of every world of ``mask`` after a call, as the error the C simulator raises
        (:mod:`~magsoft_env.sim.health`'s texts and figures): a non-finite state, an MJWarp buffer overflow (one
        of :data:`BUFFER_OVERFLOWS`), a contact deeper than ``penetration_limit`` (m; at the substep whose start
        state had it), kinetic energy above :data:`~magsoft_env.sim.health.RUNAWAY_FACTOR` x the energy scale, the
        end state's centreline below the floor by more than ``penetration_limit`` (tunnelling) and, where the C
        simulator keeps it, energy the field did not supply (a launch). ``nstep``, ``time``: each world's steps
        and time (s) now, after its ``substeps`` of this call (``sim_dt`` each); ``max_penetration`` (m),
        ``energy_drift``: its records (the drift's before this call), quoted in the figures."""
        b = self._chain()
        h = b.beam.thickness
        opts = b.options
        tc = contact_timeconst(b.beam, opts) if b.has_contact else None
        energy_on = b.has_contact and b.two_stage
        fields = self.applied_fields()
        scale = self._scale.numpy()
        over = s["overflow"] & BUFFER_OVERFLOWS
        finite = {name: np.isfinite(s[name]).all(axis=1) for name in ("qpos", "qvel")}
        lowest = self.centreline(s)[:, :, 2].min(axis=1)
        depth, ratio = s["depth"], s.get("ke_ratio")
        drift = s.get("drift")
        dt = self._dt
        out: dict[int, SimulationError] = {}
        for i in np.flatnonzero(mask).tolist():
            step, t = int(nstep[i]), float(time[i])
            numerics = setting_text(opts, fields[i])

            def unphysical(cause, reason, hint, figures, value, at=(step, t), i=i, drift_now=energy_drift[i]):
                return unphysical_error(cause, reason, hint, figures, value, step=at[0], time=at[1],
                                        setting=setting_text(opts, fields[i], contact_timeconst=tc),
                                        max_penetration=float(max_penetration[i]), thickness=h,
                                        drift=float(drift_now))

            if not finite["qpos"][i] or not finite["qvel"][i]:
                out[i] = nonfinite_error("qpos" if not finite["qpos"][i] else "qvel", step=step, time=t,
                                         setting=numerics)
            elif over[i]:
                out[i] = unstable_error(f"MJWarp buffer overflow (OverflowType bits {int(over[i])})", math.nan,
                                        OVERFLOW_HINT, step=step, time=t, setting=numerics)
            elif depth[i] > penetration_limit:
                # the substep of this call whose start state had the contact: C's check stops after it
                pen_step = step - int(substeps[i]) + int(s["depth_at"][i])
                out[i] = unphysical("penetration", penetration_reason(float(depth[i]), thickness=h,
                                                                      limit=penetration_limit, step=pen_step,
                                                                      time=pen_step * dt),
                                    PENETRATION_HINT, penetration_figures(float(depth[i]), h), float(depth[i]),
                                    at=(step, t) if pen_step + 1 == step else (pen_step + 1, (pen_step + 1) * dt))
            elif ratio is not None and not ratio[i] <= RUNAWAY_FACTOR:
                out[i] = runaway_error(float(ratio[i] * scale[i]), float(scale[i]), step=step, time=t,
                                       setting=numerics)
            elif lowest[i] < -penetration_limit:
                out[i] = unphysical("tunnelling", tunnelling_reason(float(lowest[i]), thickness=h,
                                                                    limit=penetration_limit),
                                    TUNNELLING_HINT, tunnelling_figures(float(lowest[i]), h), -float(lowest[i]))
            elif energy_on and drift is not None and drift[i] > ENERGY_DRIFT_LIMIT:
                excess = float(drift[i] * scale[i])
                out[i] = unphysical("launch", launch_reason(excess, float(drift[i]), energy_scale=float(scale[i]),
                                                            weight=b.weight, length=b.beam.length),
                                    STABILITY_HINT, {"energy_created_J": excess}, excess,
                                    drift_now=max(float(energy_drift[i]), float(drift[i])))
        return out


__all__ = ["BUFFER_OVERFLOWS", "OVERFLOW_HINT", "TOLERANCE_FLOOR", "WarpRodBatch", "warp_model_source"]
