"""The built wheel ships the assets (presets, contours, the coil calibrations), and an installed copy finds them
(not the source tree).

The wheel is installed with ``pip install --no-deps --target DIR`` and imported by the running
interpreter with ``PYTHONPATH=DIR``, outside the source tree. Its dependencies (numpy, ...) come from
the running interpreter's own environment, so the test works the same on the system interpreter and
inside a virtual environment (a venv made with ``system_site_packages=True`` sees the *base*
interpreter's packages, not the active venv's). ``PYTHONPATH`` comes before site-packages on
``sys.path``, so the installed copy shadows an editable install of the checkout; the test asserts
that the copy imported, and the assets it found, are the ones under DIR.
"""

import importlib.util
import json
import os
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _names(folder: Path) -> list[str]:
    return sorted(q.name for q in folder.iterdir())


@pytest.mark.slow
def test_wheel_install_finds_assets(tmp_path):
    if importlib.util.find_spec("pip") is None:
        pytest.skip("pip is not installed in this interpreter's environment")
    pytest.importorskip("hatchling", reason="the wheel is built without isolation (pip install -e '.[test]')")
    wheel_dir = tmp_path / "wheels"
    pip = [sys.executable, "-m", "pip", "wheel", str(ROOT), "--no-deps", "--no-build-isolation", "-q"]
    subprocess.run([*pip, "-w", str(wheel_dir)], check=True)
    wheel = next(wheel_dir.glob("magsoft_env-*.whl"))

    # the archive itself carries every preset and contour
    with zipfile.ZipFile(wheel) as zf:
        members = set(zf.namelist())
    for kind in ("presets", "contours", "fields"):
        for name in _names(ROOT / "assets" / kind):
            assert f"magsoft_env/_assets/{kind}/{name}" in members, (kind, name)

    # installed on its own (no dependencies, no source tree beside it) and imported from there
    target = tmp_path / "site"
    subprocess.run([sys.executable, "-m", "pip", "install", "-q", "--no-deps", "--target", str(target), str(wheel)],
                   check=True)
    assert not (target.parent / "assets").exists()  # the resolver's source-tree fallback cannot apply
    probe = (
        "import json, magsoft_env, magsoft_env.assets as a; "
        "p = magsoft_env.load_preset('fig3a_L25'); "
        "from magsoft_env.fields import CoilSystem; n = CoilSystem.from_calibration('navion').n_coils; "
        "print(json.dumps({'pkg': magsoft_env.__file__, 'assets': str(a.assets_dir()), 'navion_coils': n, "
        "'fields': sorted(q.name for q in (a.assets_dir() / 'fields').iterdir()), "
        "'presets': sorted(q.name for q in (a.assets_dir() / 'presets').iterdir()), "
        "'contours': sorted(q.name for q in (a.assets_dir() / 'contours').iterdir()), 'L': p.beam.length}))"
    )
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME", "PYTHONSTARTUP")}
    env["PYTHONPATH"] = str(target)
    # run outside the source tree so the checkout cannot be picked up from the working directory
    out = subprocess.run([sys.executable, "-c", probe], check=True, capture_output=True, text=True, cwd=tmp_path,
                         env=env)
    info = json.loads(out.stdout)
    site = target.resolve()
    assert Path(info["pkg"]).resolve().is_relative_to(site), info
    assert Path(info["assets"]).resolve() == site / "magsoft_env" / "_assets", info
    assert info["assets"].endswith("magsoft_env/_assets"), info
    assert info["presets"] == _names(ROOT / "assets" / "presets")
    assert info["contours"] == _names(ROOT / "assets" / "contours")
    assert info["L"] == pytest.approx(25e-3)
    assert info["fields"] == _names(ROOT / "assets" / "fields") and info["navion_coils"] == 3
