"""One resolver for the project's data files (presets, contours, scene pieces).

In a wheel the top-level ``assets/`` folder ships as ``magsoft_env/_assets``; in a source
checkout or an editable install it is found beside the package.
"""

from __future__ import annotations

from pathlib import Path

_HERE = Path(__file__).resolve().parent


def assets_dir() -> Path:
    """Folder holding the shipped assets; raises FileNotFoundError with a fix if missing."""
    for cand in (_HERE / "_assets", _HERE.parent / "assets"):
        if cand.is_dir():
            return cand
    raise FileNotFoundError(
        "magsoft_env cannot find its assets (looked in magsoft_env/_assets and ../assets). "
        "Reinstall the package: pip install --force-reinstall magsoft_env."
    )


def asset_path(*parts: str) -> Path:
    """Path of one asset, e.g. ``asset_path('presets', 'fig3.json')``; raises FileNotFoundError."""
    p = assets_dir().joinpath(*parts)
    if not p.exists():
        names = sorted(q.name for q in p.parent.glob("*")) if p.parent.is_dir() else []
        raise FileNotFoundError(f"asset {'/'.join(parts)!r} not found; available here: {names}")
    return p
