"""Field sources in the MuJoCo Warp rod batch: per-world point dipoles evaluated on the device every substep.

A field source the batch takes is a set of point dipoles per world (positions ``(nworld, K, 3)`` in m, moments
``(nworld, K, 3)`` with mu0/(4 pi) folded in, T m^3; a row whose moment is zero is no dipole, so worlds may have
fewer dipoles than ``K``, or none). :class:`~magsoft_env.fields.PointDipole`,
:class:`~magsoft_env.fields.DipoleSet` (``CoilSystem.at_currents(I)`` is one), a dipole-outside
:class:`~magsoft_env.fields.SphereMagnet`, a :class:`~magsoft_env.fields.Transformed` of these (a magnet at a pose)
and sums of them reduce to that (:func:`source_dipoles`, :func:`dipole_arrays`).

:func:`_source_loads` is the device twin of the C rod's ``PlanarRod._write_source``
(:mod:`magsoft_env.sim.planar`): for every world and piece it takes the piece's world moment ``R m`` and magnetic
centre (its midpoint, ``xpos + L/2 R e_x``) from MJWarp's kinematics of the substep, sums the field and gradient of
the world's dipoles there (docs/fields.md)::

    B = sum_k (3 r (m_k . r) / r^5 - m_k / r^3)
    G = sum_k (3 / r^5 (m_k r^T + r m_k^T) + 3 (m_k . r) / r^5 (I - 5 r r^T / r^2))

and writes the in-plane load into ``xfrc_applied``: the force ``f = G^T m`` (x and z) at the body's centre of mass
and the couple ``(m x B)_y`` plus the moment arm ``((p - xipos) x f)_y``. The uniform field stays on the rod's
pole actuators (the held field of :meth:`~magsoft_env.sim.warp_batch.WarpRodBatch.set_fields`), as the C simulator
folds a source's uniform parts into its uniform field (:func:`~magsoft_env.sim.sources.split_source`).
"""

from __future__ import annotations

import numpy as np

from .warp_extra import require_warp

wp, _ = require_warp()


@wp.func
def _field_and_gradient(w: int, p: wp.vec3, spos: wp.array2d[wp.vec3], smom: wp.array2d[wp.vec3]):
    """The field (T) and gradient (T/m, ``G[a, b] = dB_a / dx_b``) of world ``w``'s dipoles (moments in T m^3) at
    ``p`` (m), one pass over the dipoles."""
    B = wp.vec3(0.0)
    G = wp.mat33(0.0)
    for k in range(spos.shape[1]):
        mk = smom[w, k]
        if mk[0] == 0.0 and mk[1] == 0.0 and mk[2] == 0.0:
            continue
        r = p - spos[w, k]
        inv_r2 = 1.0 / wp.dot(r, r)
        inv_r3 = inv_r2 * wp.sqrt(inv_r2)
        c = 3.0 * inv_r3 * inv_r2  # 3 / r^5
        a = c * wp.dot(mk, r)  # 3 (m . r) / r^5
        B += a * r - inv_r3 * mk
        G += c * (wp.outer(mk, r) + wp.outer(r, mk)) + a * wp.identity(n=3, dtype=float) \
            - (5.0 * a * inv_r2) * wp.outer(r, r)
    return B, G


@wp.func
def _field_at(w: int, p: wp.vec3, spos: wp.array2d[wp.vec3], smom: wp.array2d[wp.vec3]) -> wp.vec3:
    """The field (T) of world ``w``'s dipoles (moments in T m^3) at ``p`` (m)."""
    B = wp.vec3(0.0)
    for k in range(spos.shape[1]):
        mk = smom[w, k]
        if mk[0] == 0.0 and mk[1] == 0.0 and mk[2] == 0.0:
            continue
        r = p - spos[w, k]
        inv_r2 = 1.0 / wp.dot(r, r)
        inv_r3 = inv_r2 * wp.sqrt(inv_r2)
        B += (3.0 * wp.dot(mk, r) * inv_r3 * inv_r2) * r - inv_r3 * mk
    return B


@wp.func
def _piece(w: int, b: int, i: int, xpos: wp.array2d[wp.vec3], xmat: wp.array2d[wp.mat33], mx: wp.array[float],
           mz: wp.array[float], half: wp.array[float]):
    """World moment ``R (m_x, 0, m_z)`` (A m^2) and magnetic centre (the midpoint, m) of piece ``i`` (body ``b``)."""
    R = xmat[w, b]
    m = wp.vec3(R[0, 0] * mx[i] + R[0, 2] * mz[i], 0.0, R[2, 0] * mx[i] + R[2, 2] * mz[i])
    p = xpos[w, b] + half[i] * wp.vec3(R[0, 0], R[1, 0], R[2, 0])
    return m, p


@wp.kernel
def _source_loads(xpos: wp.array2d[wp.vec3], xmat: wp.array2d[wp.mat33], xipos: wp.array2d[wp.vec3], b0: int,
                  mx: wp.array[float], mz: wp.array[float], half: wp.array[float], spos: wp.array2d[wp.vec3],
                  smom: wp.array2d[wp.vec3], xfrc: wp.array2d[wp.spatial_vector]):
    """The dipoles' in-plane loads on every world's pieces at the positions in ``xpos`` / ``xmat`` / ``xipos`` into
    ``xfrc_applied`` (force at the CoM, then torque): ``f = G^T m`` (x, z) and ``(m x B)_y + ((p - xipos) x f)_y``.
    Rows ``b0 + i`` (the rod's bodies, consecutive ids); dims ``(nworld, pieces)``."""
    w, i = wp.tid()
    b = b0 + i
    m, p = _piece(w, b, i, xpos, xmat, mx, mz, half)
    B, G = _field_and_gradient(w, p, spos, smom)
    fx = G[0, 0] * m[0] + G[2, 0] * m[2]
    fz = G[0, 2] * m[0] + G[2, 2] * m[2]
    r = p - xipos[w, b]
    ty = m[2] * B[0] - m[0] * B[2] + r[2] * fx - r[0] * fz
    xfrc[w, b] = wp.spatial_vector(fx, 0.0, fz, 0.0, ty, 0.0)


@wp.kernel
def _source_energy(xpos: wp.array2d[wp.vec3], xmat: wp.array2d[wp.mat33], b0: int, mx: wp.array[float],
                   mz: wp.array[float], half: wp.array[float], spos: wp.array2d[wp.vec3], smom: wp.array2d[wp.vec3],
                   out: wp.array[wp.float64]):
    """Every world's magnetic energy in its dipoles' field, ``-sum_i m_i . B(p_i)`` (J; x and z, as C's)."""
    w = wp.tid()
    e = wp.float64(0.0)
    for i in range(mx.shape[0]):
        m, p = _piece(w, b0 + i, i, xpos, xmat, mx, mz, half)
        B = _field_at(w, p, spos, smom)
        e -= wp.float64(m[0]) * wp.float64(B[0]) + wp.float64(m[2]) * wp.float64(B[2])
    out[w] = e


def source_dipoles(source) -> tuple[np.ndarray, np.ndarray]:
    """``(positions (K, 3) m, moments (K, 3) T m^3)``: ``source`` as point dipoles with mu0/(4 pi) folded in.

    Takes :class:`~magsoft_env.fields.PointDipole`, :class:`~magsoft_env.fields.DipoleSet` (``CoilSystem.at_currents``),
    :class:`~magsoft_env.fields.SphereMagnet` (its outside dipole: no piece may enter it),
    :class:`~magsoft_env.fields.Transformed` of these and :class:`~magsoft_env.fields.SourceSum` of them; None is no
    dipole. A uniform part (:class:`~magsoft_env.fields.Uniform`) is refused: hold it with ``set_fields``, the
    actuators' path (as the C simulator folds it into its uniform field)."""
    from ..fields import MU0_4PI, DipoleSet, PointDipole, SourceSum, SphereMagnet, Transformed, Uniform

    if source is None:
        return np.zeros((0, 3)), np.zeros((0, 3))
    if isinstance(source, PointDipole):
        return np.array([source.position], dtype=float), MU0_4PI * np.array([source.moment], dtype=float)
    if isinstance(source, SphereMagnet):
        return np.array([source.position], dtype=float), MU0_4PI * source.moment.reshape(1, 3)
    if isinstance(source, DipoleSet):
        return np.array(source.positions, dtype=float), source.scale * np.array(source.moments, dtype=float)
    if isinstance(source, Transformed):
        p, m = source_dipoles(source.source)
        R = np.asarray(source.rotation, dtype=float)
        return p @ R.T + source.position, m @ R.T
    if isinstance(source, SourceSum):
        parts = [source_dipoles(s) for s in source.sources]
        return np.concatenate([p for p, _ in parts]), np.concatenate([m for _, m in parts])
    if isinstance(source, Uniform):
        raise ValueError("a Uniform field is the batch's held field: set_fields((B_x, B_z) per world), not a dipole "
                         "source (the C simulator folds it into its uniform field too).")
    raise ValueError(f"the Warp batch takes point-dipole sources (PointDipole, DipoleSet, CoilSystem.at_currents(I), "
                     f"SphereMagnet, Transformed and sums of them), got {type(source).__name__}.")


def dipole_arrays(sources) -> tuple[np.ndarray, np.ndarray]:
    """Per-world sources (a sequence, one source or None per world) as ``(positions, moments)`` of shape
    ``(nworld, K, 3)`` (m; T m^3, mu0/(4 pi) folded in), ``K`` the most dipoles of any world, the rest padded with
    zero moments (no dipole): :meth:`~magsoft_env.sim.warp_batch.WarpRodBatch.set_sources` with ``scale=1``."""
    parts = [source_dipoles(s) for s in sources]
    k = max([1] + [p.shape[0] for p, _ in parts])
    pos = np.zeros((len(parts), k, 3))
    mom = np.zeros((len(parts), k, 3))
    for w, (p, m) in enumerate(parts):
        pos[w, :len(p)] = p
        mom[w, :len(m)] = m
    return pos, mom


__all__ = ["dipole_arrays", "source_dipoles"]
