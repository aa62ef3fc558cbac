"""A batch of planar rods in MuJoCo Warp: one model put once, ``nworld`` worlds, per-world fields and resets.

:class:`WarpRodBatch` puts a compiled rod model (:mod:`magsoft_env.sim.model`) on a Warp device with MuJoCo's
auto-reset flag cleared (MJWarp refuses it, and never auto-resets: a world that goes non-finite stays so, which
:meth:`WarpRodBatch.health` reports), the solver tolerance raised to MJWarp's float32 floor and contact buffers
sized for the rod. :meth:`WarpRodBatch.advance` runs ``k`` substeps of every world under its own held field,
recorded once as a Warp graph (``wp.ScopedCapture``, on the CPU device too) and replayed at every call, or
launched kernel by kernel (``graph=False``: the same numbers, bit for bit). After every substep a small kernel
reduces each world's centreline (the state that substep started from, as MuJoCo's history buffers hold it in C)
to the crawl limits' figures, and another its deepest contact; the end state's kinematics and ``M qvel`` (for
the kinetic energy) close the graph. Worlds are reset by mask from states the caller computes in C
(:meth:`WarpRodBatch.reset_worlds`).
"""

from __future__ import annotations

import copy
import math

import mujoco
import numpy as np

from .model import field_controls
from .warp_extra import require_warp

wp, mjw = require_warp()

#: MJWarp's float32 solver stops at this tolerance at best (the C rods use 1e-8).
TOLERANCE_FLOOR = 1e-6
#: Overflow bits that mean a world's contacts or constraints did not fit its buffers (the solver's iteration
#: caps, which C also hits silently, are not failures).
BUFFER_OVERFLOWS = int(mjw.OverflowType.NEFC | mjw.OverflowType.NJMAX_NNZ | mjw.OverflowType.BROADPHASE
                       | mjw.OverflowType.NARROWPHASE | mjw.OverflowType.CCD | mjw.OverflowType.CONTACT_MATCH
                       | mjw.OverflowType.NVMAX)


@wp.kernel
def _write_inputs(mag: wp.array[float], quat: wp.array2d[float], mocap: int, ctrl: wp.array2d[float],
                  mocap_quat: wp.array2d[wp.quat]):
    w, u = wp.tid()
    ctrl[w, u] = mag[w]
    if u == 0:
        mocap_quat[w, mocap] = wp.quat(quat[w, 0], quat[w, 1], quat[w, 2], quat[w, 3])  # MuJoCo's order, w first


@wp.kernel
def _clear_records(clear_max: wp.array[float], cos_min: wp.array[float], airborne: wp.array[int],
                   violation: wp.array[int], figures: wp.array2d[float], depth: wp.array[float]):
    w = wp.tid()
    clear_max[w] = -1.0e30
    cos_min[w] = 1.0e30
    airborne[w] = 0
    violation[w] = -1
    figures[w, 0] = 0.0
    figures[w, 1] = 0.0
    figures[w, 2] = 0.0
    depth[w] = -1.0e30


@wp.kernel
def _limits(xpos: wp.array2d[wp.vec3], xmat: wp.array2d[wp.mat33], bodies: wp.array[int],
            inv_len: wp.array[float], tip_len: float, half_h: float, max_clearance: float, cos_rotation: float,
            max_height: float, mode: int, airborne_tol: float, column: int, count: int,
            clear_max: wp.array[float], cos_min: wp.array[float], airborne: wp.array[int],
            violation: wp.array[int], figures: wp.array2d[float]):
    """One column of the crawl limits of every world: clearance of the lowest centreline point, the highest point
    and the cos of the largest piece angle; the first column that breaks a limit is kept with its figures.
    ``mode``: 0 none, 1 rotation, 2 height."""
    w = wp.tid()
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
            violation[w] = column
            figures[w, 0] = clear
            figures[w, 1] = hi
            figures[w, 2] = cmin


@wp.kernel
def _deepest(nacon: wp.array[int], dist: wp.array[float], worldid: wp.array[int], depth: wp.array[float]):
    c = wp.tid()
    if c < nacon[0]:
        wp.atomic_max(depth, worldid[c], -dist[c])


@wp.kernel
def _reset_masked(mask: wp.array[int], qpos_new: wp.array2d[float], qvel_new: wp.array2d[float],
                  qpos: wp.array2d[float], qvel: wp.array2d[float], qacc_warmstart: wp.array2d[float],
                  time: wp.array[float], overflow: wp.array[int]):
    w = wp.tid()
    if mask[w] == 0:
        return
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
        1 rotation, 2 height), ``airborne_tolerance`` (m).
    device : str, optional
        Warp device (None: Warp's default, a GPU where there is one).
    graph : bool
        Record :meth:`advance` as a graph and replay it (False: launch the kernels each call).
    nconmax, njmax : int, optional
        Contacts and constraint rows per world (None: sized for the rod lying flat, with room to spare).
    """

    def __init__(self, rod, data: mujoco.MjData, nworld: int, *, limits: dict | None = None, device=None,
                 graph: bool = True, nconmax: int | None = None, njmax: int | None = None):
        self.rod = rod
        self.nworld = int(nworld)
        self.device = wp.get_device(device)
        src = warp_model_source(rod.model)
        self.source = src
        ngeom = int(src.ngeom)
        self.nconmax = int(nconmax) if nconmax is not None else 4 * ngeom + 16
        rows = 6 if src.opt.cone == mujoco.mjtCone.mjCONE_PYRAMIDAL else 3
        self.njmax = int(njmax) if njmax is not None else rows * self.nconmax + int(src.nv)
        with wp.ScopedDevice(self.device):
            self.m = mjw.put_model(src)
            self.m.opt.warn_overflow = 0  # recorded per world in d.overflow, read by health()
            self.m.opt.contact_sensor_maxmatch = max(int(self.m.opt.contact_sensor_maxmatch), self.nconmax)
            self.d = mjw.put_data(src, data, nworld=self.nworld, nconmax=self.nconmax, njmax=self.njmax)
            n = self.nworld
            self._mag = wp.zeros(n, dtype=float)
            self._quat = wp.array(np.tile([1.0, 0.0, -0.0, 0.0], (n, 1)), dtype=float)
            self.clear_max = wp.zeros(n, dtype=float)
            self.cos_min = wp.zeros(n, dtype=float)
            self.airborne = wp.zeros(n, dtype=int)
            self.violation = wp.zeros(n, dtype=int)
            self.figures = wp.zeros((n, 3), dtype=float)
            self.depth = wp.zeros(n, dtype=float)
            self.mqvel = wp.zeros((n, int(src.nv)), dtype=float)
            self._mask = wp.zeros(n, dtype=int)
            self._qpos_new = wp.zeros((n, int(src.nq)), dtype=float)
            self._qvel_new = wp.zeros((n, int(src.nv)), dtype=float)
            self._bodies = wp.array(np.asarray(rod.body_ids, dtype=np.int32), dtype=int)
            disc = rod.disc
            lim = dict(limits or {})
            inv = lim.get("inv_piece_length", 1.0 / np.asarray(disc.piece_length))
            self._inv_len = wp.array(np.asarray(inv, dtype=np.float32).ravel(), dtype=float)
        self._tip_len = float(disc.piece_length[-1])
        self._half_h = float(lim.get("half_thickness", 0.0))
        self._max_clearance = float(lim.get("max_clearance", math.inf))
        self._cos_rotation = float(lim.get("cos_rotation", -2.0))
        self._max_height = float(lim.get("max_height", math.inf))
        self._mode = int(lim.get("mode", 0))
        self._airborne_tol = float(lim.get("airborne_tolerance", math.inf))
        self._mocap = int(rod.field_mocap) if getattr(rod, "field_mocap", -1) is not None else -1
        self.graph = bool(graph)
        self._graphs: dict[int, object] = {}

    # ------------------------------------------------------------------ inputs and the step
    def set_fields(self, fields: np.ndarray) -> None:
        """Hold the fields ``(nworld, 2)`` (B_x, B_z; T), one per world, from the next :meth:`advance` on."""
        mag, quat = field_controls(np.asarray(fields, dtype=float).reshape(self.nworld, 2))
        self._mag.assign(mag.astype(np.float32))
        self._quat.assign(quat.astype(np.float32))

    def _limit_launch(self, column: int, count: int) -> None:
        wp.launch(_limits, dim=self.nworld, inputs=[
            self.d.xpos, self.d.xmat, self._bodies, self._inv_len, self._tip_len, self._half_h,
            self._max_clearance, self._cos_rotation, self._max_height, self._mode, self._airborne_tol, column,
            count, self.clear_max, self.cos_min, self.airborne, self.violation, self.figures])

    def _launches(self, k: int) -> None:
        m, d, n = self.m, self.d, self.nworld
        if self._mocap >= 0 and m.nu:
            wp.launch(_write_inputs, dim=(n, int(m.nu)), inputs=[self._mag, self._quat, self._mocap, d.ctrl,
                                                                 d.mocap_quat])
        wp.launch(_clear_records, dim=n, inputs=[self.clear_max, self.cos_min, self.airborne, self.violation,
                                                 self.figures, self.depth])
        for j in range(k):
            mjw.step(m, d)
            # xpos / xmat now hold the state this substep started from (MuJoCo's history buffers in C)
            self._limit_launch(j, 1)
            wp.launch(_deepest, dim=d.naconmax, inputs=[d.nacon, d.contact.dist, d.contact.worldid, self.depth])
        self._close()

    def _close(self) -> None:
        mjw.kinematics(self.m, self.d)  # the end state's positions (readouts), as the C simulator's sync
        mjw.mul_m(self.m, self.d, self.mqvel, self.d.qvel)
        self._limit_launch(-2, 0)  # column -2: the end state (the caller names its time)

    def advance(self, k: int) -> None:
        """``k`` substeps of every world under its held field; afterwards the records (:attr:`clear_max`,
        :attr:`cos_min`, :attr:`airborne`, :attr:`violation` with :attr:`figures`, :attr:`depth`) cover the
        ``k`` substeps' start states and the end state, whose positions (``xpos``, ``xmat``, ``xipos``) are
        computed. A graph per ``k``, recorded at its first call."""
        k = int(k)
        with wp.ScopedDevice(self.device):
            if not self.graph:
                self._launches(k)
                return
            g = self._graphs.get(k)
            if g is None:
                with wp.ScopedCapture() as capture:
                    self._launches(k)
                g = self._graphs[k] = capture.graph
            wp.capture_launch(g)

    # ------------------------------------------------------------------ resets
    def reset_worlds(self, mask: np.ndarray, qpos: np.ndarray, qvel: np.ndarray) -> None:
        """Set the worlds of boolean ``mask`` to ``qpos`` / ``qvel`` rows (``(nworld, nq)``, ``(nworld, nv)``; only
        the masked rows are read), time zero, warm start and overflow flags cleared; the others are untouched
        (their positions are recomputed from the same state)."""
        mask = np.asarray(mask, dtype=bool)
        if not mask.any():
            return
        with wp.ScopedDevice(self.device):
            self._mask.assign(mask.astype(np.int32))
            self._qpos_new.assign(np.asarray(qpos, dtype=np.float32))
            self._qvel_new.assign(np.asarray(qvel, dtype=np.float32))
            d = self.d
            wp.launch(_reset_masked, dim=self.nworld, inputs=[self._mask, self._qpos_new, self._qvel_new, d.qpos,
                                                              d.qvel, d.qacc_warmstart, d.time, d.overflow])
            mjw.kinematics(self.m, d)
            mjw.mul_m(self.m, d, self.mqvel, d.qvel)

    # ------------------------------------------------------------------ readouts (host copies)
    def state(self) -> dict[str, np.ndarray]:
        """Host copies (float64) of what the env reads: ``qpos``, ``qvel``, ``xpos`` / ``xmat`` / ``xipos`` of
        the rod's bodies (chain order), the substep records, the deepest contact, ``M qvel`` and the overflow
        bits."""
        b = np.asarray(self.rod.body_ids)
        d = self.d
        return {
            "qpos": d.qpos.numpy().astype(float), "qvel": d.qvel.numpy().astype(float),
            "xpos": d.xpos.numpy()[:, b].astype(float), "xmat": d.xmat.numpy()[:, b].astype(float),
            "xipos": d.xipos.numpy()[:, b].astype(float),
            "clear_max": self.clear_max.numpy().astype(float), "cos_min": self.cos_min.numpy().astype(float),
            "airborne": self.airborne.numpy().astype(int), "violation": self.violation.numpy().astype(int),
            "figures": self.figures.numpy().astype(float), "depth": self.depth.numpy().astype(float),
            "mqvel": self.mqvel.numpy().astype(float), "overflow": d.overflow.numpy().astype(np.int64),
        }

    def qpos(self) -> np.ndarray:
        """Joint positions of every world, ``(nworld, nq)`` (float64 copy)."""
        return self.d.qpos.numpy().astype(float)


__all__ = ["BUFFER_OVERFLOWS", "TOLERANCE_FLOOR", "WarpRodBatch", "warp_model_source"]
