"""Electromagnetic navigation systems from MPEM calibrations: fields linear in the coil currents.

An MPEM calibration (Petruska et al., *Model-based calibration for magnetic manipulation*, IEEE Trans. Magn. 53,
2017) describes each coil's field per ampere as a sum of point dipoles. The dipole-only YAML files read here list
the coils under ``Coil_List``; each coil lists its sources under ``Source_List``; each source has ``B_Coeff``
(one number, T m^3 / A, with mu0/(4 pi) folded in), ``Source_Direction`` and ``Source_Position`` (m), and
``A_Coeff: ~``. The field of coil ``j`` per ampere is::

    b_j(x) = sum over its sources of (3 r_hat (m . r_hat) - m) / r^3,   m = B_Coeff * Source_Direction,  r = x - p

and ``B(x) = sum_j I_j b_j(x)``, with the directions as written. The MPEM reader of ethz-msrl's Tesla framework
normalizes each direction first (``normalize_directions=True`` does too): the shipped measured calibrations'
directions are unit vectors within 5e-10 (Navion's field moves by up to 2e-9 relative), the ideal OctoMag's,
rounded to 4 digits, within 7.6e-5. A coil named ``Offset`` in ``Coil_List`` is a field independent of the
currents, added to it (as the MPEM reader does); an ``Offset`` block not listed there is ignored (CardioMag's
file has one: its field would be 1.46 mT at the centre). ``Workspace_Dimensions`` (m) is kept as
:attr:`CoilSystem.workspace`. The optional top-level key ``Max_Current`` (A: one number, or one per coil) is this
package's, for the current limits; the shipped files have none and take the limits of :data:`CALIBRATIONS`.
"""

from __future__ import annotations

import difflib
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..assets import asset_path
from ..validate import boolean, finite_array
from .base import MAX_COORDINATE, Source, SourceSum, as_points, position3
from .dipole import DipoleSet, dipole_sum

#: Largest current limit accepted (A): coils of navigation systems run at tens of amperes.
MAX_COIL_CURRENT = 1000.0
#: A coil named this (in Coil_List) is the current-independent offset field.
OFFSET_COIL = "Offset"
#: Rows of :meth:`CoilSystem.actuation_matrix`: the field and the five independent gradient entries (MPEM order).
ACTUATION_ROWS = ("Bx", "By", "Bz", "dBx/dx", "dBx/dy", "dBx/dz", "dBy/dy", "dBy/dz")


@dataclass(frozen=True)
class Calibration:
    """A shipped calibration: its file under ``assets/fields/``, the current limit of each coil (A) and where the
    limit comes from."""

    file: str
    max_current: float
    description: str


#: Named coil systems (files from ethz-msrl/Workspace_eMNS, commit 524f851; Apache-2.0, assets/fields/NOTICE.md).
#: Limits: the ones that repository's notebooks use (Navion +-35 A, CardioMag +-20 A, the ideal 2-coil and
#: 8-coil systems +-1 A, the 3-coil one +-3 A); the 4-coil systems, used by none of them, get 1 A.
CALIBRATIONS = {
    "navion": Calibration("Navion_2_Calibration_24-02-2020.yaml", 35.0, "Navion (3 coils), calibrated 2020-02-24"),
    "cardiomag": Calibration("C_Mag_Calibration_06-25-2015_no_offset.yaml", 20.0,
                             "CardioMag (8 coils), calibrated 2015-06-25"),
    "2coils_45deg": Calibration("mns_2coils_45deg.yaml", 1.0, "ideal: 2 dipoles 0.15 m out, axes 45 deg apart"),
    "2coils_90deg": Calibration("mns_2coils_90deg.yaml", 1.0, "ideal: 2 dipoles 0.15 m out, axes 90 deg apart"),
    "2coils_135deg": Calibration("mns_2coils_135deg.yaml", 1.0, "ideal: 2 dipoles 0.15 m out, axes 135 deg apart"),
    "2coils_180deg": Calibration("mns_2coils_180deg.yaml", 1.0, "ideal: 2 dipoles 0.15 m out, facing"),
    "2coils_parallel_50": Calibration("mns_2coils_parallel_50.yaml", 1.0, "ideal: 2 parallel dipoles"),
    "2coils_parallel_100": Calibration("mns_2coils_parallel_100.yaml", 1.0, "ideal: 2 parallel dipoles"),
    "2coils_parallel_150": Calibration("mns_2coils_parallel_150.yaml", 1.0, "ideal: 2 parallel dipoles"),
    "2coils_parallel_200": Calibration("mns_2coils_parallel_200.yaml", 1.0, "ideal: 2 parallel dipoles"),
    "3coils_triangle": Calibration("mns_3coils_triangle.yaml", 3.0, "ideal: 3 dipoles 120 deg apart"),
    "4coils_1": Calibration("mns_4coils_1.yaml", 1.0, "ideal: 4 dipoles"),
    "4coils_2": Calibration("mns_4coils_2.yaml", 1.0, "ideal: 4 dipoles"),
    "octomag": Calibration("mns_8coils_octomag.yaml", 1.0, "ideal: 8 dipoles, OctoMag-like"),
}


def _number(where: str, value) -> float:
    """A finite number from a YAML value (a float, an int, or a string such as '1e-4' that YAML 1.1 leaves
    unparsed); a ValueError naming ``where`` otherwise."""
    if isinstance(value, bool) or value is None:
        raise ValueError(f"{where} must be a finite number, got {value!r}.")
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{where} must be a finite number, got {value!r}.") from None
    if not math.isfinite(x):
        raise ValueError(f"{where} must be a finite number, got {value!r}.")
    return x


def _triple(where: str, value) -> np.ndarray:
    if not isinstance(value, (list, tuple)) or len(value) != 3:
        raise ValueError(f"{where} must be a list of 3 numbers, got {value!r}.")
    return np.array([_number(f"{where}[{i}]", v) for i, v in enumerate(value)])


def _read_coil(data: dict, coil: str, where: str, normalize: bool) -> tuple[np.ndarray, np.ndarray]:
    """(positions (k, 3) m, moments (k, 3) T m^3 / A) of one coil's sources."""
    block = data.get(coil)
    if not isinstance(block, dict):
        raise ValueError(f"{where}: coil {coil!r} (in Coil_List) has no block {coil}: with a Source_List.")
    names = block.get("Source_List")
    if not isinstance(names, list) or not names:
        raise ValueError(f"{where}: {coil}.Source_List must be a non-empty list of source names, got {names!r}.")
    pos, mom = [], []
    for s in names:
        key = f"{coil}.{s}"
        src = block.get(s)
        if not isinstance(src, dict):
            raise ValueError(f"{where}: source {key} (in {coil}.Source_List) has no block.")
        for k in ("B_Coeff", "Source_Direction", "Source_Position"):
            if k not in src:
                raise ValueError(f"{where}: {key} has no {k}.")
        a = src.get("A_Coeff")
        if a not in (None, []):
            raise ValueError(f"{where}: {key}.A_Coeff must be ~ (dipole-only MPEM), got {a!r}: higher-order "
                             "sources are not supported.")
        b = src["B_Coeff"]
        if not isinstance(b, list) or len(b) != 1:
            raise ValueError(f"{where}: {key}.B_Coeff must be a list of one number (dipole-only MPEM), got {b!r}.")
        coeff = _number(f"{where}: {key}.B_Coeff[0]", b[0])
        d = _triple(f"{where}: {key}.Source_Direction", src["Source_Direction"])
        n = float(np.linalg.norm(d))
        if n == 0.0:
            raise ValueError(f"{where}: {key}.Source_Direction must not be zero, got {src['Source_Direction']!r}.")
        p = _triple(f"{where}: {key}.Source_Position", src["Source_Position"])
        if np.abs(p).max() > MAX_COORDINATE:
            raise ValueError(f"{where}: {key}.Source_Position must lie within {MAX_COORDINATE:g} m (metres), "
                             f"got {p.tolist()!r}.")
        pos.append(p)
        mom.append(coeff * (d / n if normalize else d))
    return np.array(pos), np.array(mom)


def read_mpem(path, *, normalize_directions: bool = False) -> dict:
    """The contents of a dipole-only MPEM calibration file, checked (a ValueError naming the file and the key).

    The moments are ``B_Coeff * Source_Direction`` as written, or with the direction normalized first if
    ``normalize_directions`` (as the MPEM reader of ethz-msrl's Tesla framework does).

    Returns a dict: ``system_name``, ``coil_names`` (tuple), ``positions`` / ``moments`` (per coil, arrays (k, 3):
    m and T m^3 / A), ``offset`` (positions, moments, or None), ``workspace`` ((3, 2) m or None), ``max_current``
    (None, a number or a list, A).
    """
    import yaml  # a dependency of the package; read only when a file is

    path = Path(path)
    where = str(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ValueError(f"calibration file {where!r} does not exist (shipped systems by name: "
                         f"{', '.join(CALIBRATIONS)}).") from None
    except IsADirectoryError:
        raise ValueError(f"calibration file {where!r} is a folder, not a YAML file.") from None
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise ValueError(f"{where}: not valid YAML ({' '.join(str(exc).split())}).") from None
    if not isinstance(data, dict):
        raise ValueError(f"{where}: an MPEM calibration is a YAML mapping with Coil_List, got {type(data).__name__}.")
    coils = data.get("Coil_List")
    if not isinstance(coils, list) or not coils or not all(isinstance(c, str) for c in coils):
        raise ValueError(f"{where}: Coil_List must be a non-empty list of coil names, got {coils!r}.")
    if len(set(coils)) != len(coils):
        raise ValueError(f"{where}: Coil_List names a coil twice: {coils!r}.")
    names = [c for c in coils if c != OFFSET_COIL]
    if not names:
        raise ValueError(f"{where}: Coil_List has no coil besides {OFFSET_COIL!r}.")
    per_coil = [_read_coil(data, c, where, normalize_directions) for c in names]
    offset = _read_coil(data, OFFSET_COIL, where, normalize_directions) if OFFSET_COIL in coils else None
    ws = data.get("Workspace_Dimensions")
    workspace = None
    if ws is not None:
        if not isinstance(ws, list) or len(ws) != 3 or not all(isinstance(r, list) and len(r) == 2 for r in ws):
            raise ValueError(f"{where}: Workspace_Dimensions must be 3 pairs [min, max] (m), got {ws!r}.")
        workspace = np.array([[_number(f"{where}: Workspace_Dimensions[{i}][{j}]", v) for j, v in enumerate(r)]
                              for i, r in enumerate(ws)])
        if (workspace[:, 0] > workspace[:, 1]).any():
            raise ValueError(f"{where}: Workspace_Dimensions must have min <= max on each axis, got {ws!r}.")
    name = data.get("System_Name")
    return {"system_name": str(name) if name is not None else path.stem, "coil_names": tuple(names),
            "positions": [p for p, _ in per_coil], "moments": [m for _, m in per_coil], "offset": offset,
            "workspace": workspace, "max_current": data.get("Max_Current")}


def _limits(value, n: int, coil_names, where: str) -> np.ndarray:
    """Per-coil current limits (A), shape (n,), each in (0, MAX_COIL_CURRENT]."""
    if isinstance(value, (list, tuple, np.ndarray)):
        arr = finite_array(where, value)
        if arr.shape != (n,):
            raise ValueError(f"{where} must be one limit (A) or one per coil ({n}: {', '.join(coil_names)}), got "
                             f"{np.asarray(value).tolist()!r}.")
    else:
        arr = np.full(n, _number(where, value))
    for j, v in enumerate(arr):
        if not 0.0 < v <= MAX_COIL_CURRENT:
            raise ValueError(f"{where} for coil {j} ({coil_names[j]}) must lie in (0, {MAX_COIL_CURRENT:g}] A, got "
                             f"{float(v)!r}.")
    return arr


@dataclass(frozen=True, eq=False, init=False)
class CoilSystem:
    """An electromagnetic navigation system: coils whose fields are sums of point dipoles, linear in the currents.

    Build one from a calibration: ``CoilSystem.from_calibration("navion")`` (a name of :data:`CALIBRATIONS`) or
    ``CoilSystem.from_calibration("my_system.yaml", max_current=20.0)`` (an MPEM file).

    Parameters
    ----------
    coil_names : sequence of str
        One name per coil (n coils).
    positions, moments : sequence of array_like, each of shape (k_j, 3)
        Per coil, its sources' positions (m) and moments per ampere with mu0/(4 pi) folded in (T m^3 / A, the
        MPEM ``B_Coeff * Source_Direction``).
    max_current : float or array_like, shape (n,)
        Current limit of each coil (A): the linear model is valid within it only (real coils saturate), and
        currents beyond it are refused.
    name : str
        What to call it in messages.
    offset : (positions, moments) or None
        Sources of a current-independent field (T m^3), added at any currents.
    workspace : array_like, shape (3, 2), or None
        The calibrated region, ``[[xmin, xmax], [ymin, ymax], [zmin, zmax]]`` (m), for information.

    Notes
    -----
    :meth:`field_and_gradient` with currents ``I`` (A) is the dipole sum with moments ``I_j m`` (exact for the
    model); :meth:`actuation_matrix` is the (8, n) map from currents to the field and its five independent
    gradient entries (:data:`ACTUATION_ROWS`; the gradient of a source-free field is symmetric and traceless).
    The model module docstring has the formula and the file format.

    Examples
    --------
    >>> import numpy as np
    >>> navion = CoilSystem.from_calibration("navion")
    >>> (navion.actuation_matrix([0, 0, 0])[:3] * 1e3).round(3).T.tolist()   # mT/A per coil at the centre
    [[0.0, -0.291, -0.414], [-0.388, 0.33, -0.199], [0.385, 0.323, -0.192]]
    """

    name: str
    coil_names: tuple
    max_current: np.ndarray
    source_positions: np.ndarray
    source_moments: np.ndarray
    source_coil: np.ndarray
    offset: DipoleSet | None
    workspace: np.ndarray | None

    def __init__(self, *, coil_names, positions, moments, max_current, name: str = "coil system", offset=None,
                 workspace=None):
        if not isinstance(name, str) or not name:
            raise ValueError(f"CoilSystem name must be a non-empty string, got {name!r}.")
        where = f"CoilSystem {name!r}"
        if isinstance(coil_names, str) or not all(isinstance(c, str) for c in coil_names) or not coil_names:
            raise ValueError(f"{where} coil_names must be a non-empty sequence of strings, got {coil_names!r}.")
        names = tuple(coil_names)
        n = len(names)
        if len(positions) != n or len(moments) != n:
            raise ValueError(f"{where} needs one positions and one moments array per coil ({n}), got "
                             f"{len(positions)} and {len(moments)}.")
        pos, mom, idx = [], [], []
        for j in range(n):
            p = finite_array(f"{where} positions[{j}] ({names[j]})", positions[j])
            m = finite_array(f"{where} moments[{j}] ({names[j]})", moments[j])
            if p.ndim != 2 or p.shape[1] != 3 or p.shape[0] == 0 or m.shape != p.shape:
                raise ValueError(f"{where} positions[{j}] and moments[{j}] ({names[j]}) must both have shape (k, 3), "
                                 f"k >= 1, got {p.shape} and {m.shape}.")
            pos.append(p)
            mom.append(m)
            idx.append(np.full(p.shape[0], j))
        object.__setattr__(self, "name", name)
        object.__setattr__(self, "coil_names", names)
        object.__setattr__(self, "max_current", _limits(max_current, n, names, f"{where} max_current"))
        object.__setattr__(self, "source_positions", np.concatenate(pos))
        object.__setattr__(self, "source_moments", np.concatenate(mom))
        object.__setattr__(self, "source_coil", np.concatenate(idx))
        off = None
        if offset is not None:
            op, om = offset
            off = DipoleSet(op, om, scale=1.0)
        object.__setattr__(self, "offset", off)
        if workspace is not None:
            workspace = finite_array(f"{where} workspace", workspace)
            if workspace.shape != (3, 2):
                raise ValueError(f"{where} workspace must have shape (3, 2) (m), got {workspace.shape}.")
        object.__setattr__(self, "workspace", workspace)
        object.__setattr__(self, "_pos_T", np.ascontiguousarray(self.source_positions.T))
        object.__setattr__(self, "_per_coil", [(np.ascontiguousarray(p.T), m, np.ascontiguousarray(m.T))
                                               for p, m in zip(pos, mom, strict=True)])

    # ------------------------------------------------------------------------------------------ construction

    @classmethod
    def from_file(cls, path, *, max_current=None, name: str | None = None,
                  normalize_directions: bool = False) -> CoilSystem:
        """A coil system from an MPEM calibration file (YAML; module docstring).

        ``max_current`` (A, one or one per coil) overrides the file's ``Max_Current``; one of them is needed.
        ``normalize_directions``: normalize each ``Source_Direction`` first, as the MPEM reader does."""
        data = read_mpem(path, normalize_directions=boolean("normalize_directions", normalize_directions))
        limit = max_current
        if limit is None:
            if data["max_current"] is None:
                raise ValueError(f"{path}: the file has no Max_Current; pass max_current= (A, one per coil or one "
                                 f"for all) for its {len(data['coil_names'])} coils: the model holds within the "
                                 "limits only.")
            limit = _limits(data["max_current"], len(data["coil_names"]), data["coil_names"], f"{path}: Max_Current")
        return cls(coil_names=data["coil_names"], positions=data["positions"], moments=data["moments"],
                   max_current=limit, name=name or data["system_name"], offset=data["offset"],
                   workspace=data["workspace"])

    @classmethod
    def from_calibration(cls, source: str, *, max_current=None, normalize_directions: bool = False) -> CoilSystem:
        """A named system of :data:`CALIBRATIONS` (``"navion"``, ``"cardiomag"``, the ideal ones), or an MPEM file
        (a path ending in .yaml or .yml); ``max_current`` (A) overrides the limits; ``normalize_directions`` as
        :meth:`from_file`."""
        if not isinstance(source, (str, Path)):
            raise ValueError(f"CoilSystem.from_calibration takes a name ({', '.join(CALIBRATIONS)}) or a .yaml file, "
                             f"got {source!r}.")
        key = str(source)
        if key in CALIBRATIONS:
            cal = CALIBRATIONS[key]
            path = asset_path("fields", cal.file)
            return cls.from_file(path, max_current=cal.max_current if max_current is None else max_current,
                                 name=key, normalize_directions=normalize_directions)
        if key.lower().endswith((".yaml", ".yml")) or Path(key).exists():
            return cls.from_file(key, max_current=max_current, normalize_directions=normalize_directions)
        hint = difflib.get_close_matches(key.lower(), list(CALIBRATIONS), n=1, cutoff=0.5)
        extra = f" Did you mean {hint[0]!r}?" if hint else ""
        raise ValueError(f"unknown coil system {key!r}: give one of {', '.join(CALIBRATIONS)} or an MPEM .yaml "
                         f"file.{extra}")

    # ------------------------------------------------------------------------------------------ evaluation

    @property
    def n_coils(self) -> int:
        """Number of coils."""
        return len(self.coil_names)

    def check_currents(self, currents) -> np.ndarray:
        """``currents`` (A) as an array of shape (n_coils,), each within its coil's limit; a ValueError naming the
        coil otherwise."""
        I = finite_array(f"{self.name} currents", currents)
        if I.shape != (self.n_coils,):
            raise ValueError(f"{self.name} currents must have shape ({self.n_coils},) (A, one per coil: "
                             f"{', '.join(self.coil_names)}), got shape {I.shape}.")
        over = np.abs(I) > self.max_current
        if over.any():
            j = int(np.argmax(over))
            raise ValueError(f"{self.name} currents[{j}] ({self.coil_names[j]}) = {float(I[j])!r} A exceeds its limit "
                             f"+-{self.max_current[j]:g} A (the linear model holds within the limits only).")
        return I

    def field_and_gradient(self, points, currents) -> tuple[np.ndarray, np.ndarray]:
        """Field (T, (n, 3)) and gradient (T/m, (n, 3, 3)) at ``points`` (m, (n, 3)) for coil ``currents`` (A,
        (n_coils,)), plus the offset field if the file has one."""
        p = as_points(points)
        I = self.check_currents(currents)
        m = self.source_moments * I[self.source_coil][:, None]
        B, G = dipole_sum(p, self._pos_T, m, np.ascontiguousarray(m.T), scale=1.0, what="a calibration source")
        if self.offset is not None:
            b, g = self.offset.field_and_gradient(p)
            B += b
            G += g
        return B, G

    def field(self, points, currents) -> np.ndarray:
        """The field (T), shape (n, 3), at ``points`` for ``currents`` (A)."""
        return self.field_and_gradient(points, currents)[0]

    def at_currents(self, currents) -> Source:
        """The system at fixed ``currents`` (A) as a field source (a :class:`DipoleSet`, plus the offset)."""
        I = self.check_currents(currents)
        src = DipoleSet(self.source_positions, self.source_moments * I[self.source_coil][:, None], scale=1.0)
        return src if self.offset is None else SourceSum([src, self.offset])

    def unit_fields(self, points) -> tuple[np.ndarray, np.ndarray]:
        """Each coil's field and gradient per ampere at ``points`` (m, (n, 3)): shapes (n, 3, n_coils) in T/A and
        (n, 3, 3, n_coils) in T/(m A). The offset is not included."""
        p = as_points(points)
        Bs, Gs = zip(*(dipole_sum(p, pt, m, mt, scale=1.0, what="a calibration source")
                       for pt, m, mt in self._per_coil), strict=True)
        return np.stack(Bs, axis=-1), np.stack(Gs, axis=-1)

    def actuation_matrix(self, point, *, full: bool = False) -> np.ndarray:
        """The linear map from currents (A) to the field and gradient at ``point`` (m, shape (3,)).

        Returns shape (8, n_coils): rows :data:`ACTUATION_ROWS` (B in T/A, then dBx/dx, dBx/dy, dBx/dz, dBy/dy,
        dBy/dz in T/(m A): the independent entries of the symmetric, traceless gradient; the MPEM order). With
        ``full=True``, shape (12, n_coils): B, then all nine ``G[a, b]`` row by row."""
        x = position3("actuation_matrix point", point).reshape(1, 3)
        Bk, Gk = self.unit_fields(x)
        G = Gk[0]
        if full:
            return np.concatenate([Bk[0], G.reshape(9, -1)])
        return np.concatenate([Bk[0], G[0, 0:3], G[1, 1:3]])

    def max_field(self, point) -> np.ndarray:
        """The largest ``|B_x|``, ``|B_y|``, ``|B_z|`` (T, shape (3,)) each reachable at ``point`` (m) within the
        current limits, each on its own (the others free): ``sum_j |b_aj| I_max,j``. The offset is not included."""
        A = self.actuation_matrix(point)[:3]
        return np.abs(A) @ self.max_current

    def __repr__(self) -> str:
        limits = np.unique(self.max_current)
        lim = f"{limits[0]:g} A" if limits.size == 1 else f"{self.max_current.tolist()} A"
        return (f"CoilSystem({self.name!r}: {self.n_coils} coils, {self.source_positions.shape[0]} dipole sources, "
                f"limits {lim}{', offset' if self.offset is not None else ''})")


__all__ = ["ACTUATION_ROWS", "CALIBRATIONS", "Calibration", "CoilSystem", "read_mpem"]
