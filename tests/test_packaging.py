"""The built wheel ships the assets, and an installed copy finds them (not the source tree)."""

import json
import subprocess
import sys
import venv
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.slow
def test_wheel_install_finds_assets(tmp_path):
    wheel_dir = tmp_path / "wheels"
    pip = [sys.executable, "-m", "pip", "wheel", str(ROOT), "--no-deps", "--no-build-isolation", "-q"]
    subprocess.run([*pip, "-w", str(wheel_dir)], check=True)
    wheel = next(wheel_dir.glob("magsoft_env-*.whl"))
    env_dir = tmp_path / "venv"
    venv.create(env_dir, system_site_packages=True, with_pip=True)
    py = env_dir / "bin" / "python"
    subprocess.run([str(py), "-m", "pip", "install", "-q", "--no-deps", str(wheel)], check=True)
    probe = (
        "import json, magsoft_env, magsoft_env.assets as a; "
        "p = magsoft_env.load_preset('fig3a_L25'); "
        "print(json.dumps({'pkg': magsoft_env.__file__, 'assets': str(a.assets_dir()), "
        "'presets': sorted(q.name for q in (a.assets_dir() / 'presets').iterdir()), "
        "'contours': sorted(q.name for q in (a.assets_dir() / 'contours').iterdir()), 'L': p.beam.length}))"
    )
    # run outside the source tree so the checkout cannot be picked up by accident
    out = subprocess.run([str(py), "-c", probe], check=True, capture_output=True, text=True, cwd=tmp_path)
    info = json.loads(out.stdout)
    assert str(env_dir) in info["pkg"], info
    assert info["assets"].endswith("magsoft_env/_assets"), info
    shipped = sorted(q.name for q in (ROOT / "assets" / "presets").iterdir())
    assert info["presets"] == shipped
    assert info["contours"] == sorted(q.name for q in (ROOT / "assets" / "contours").iterdir())
    assert info["L"] == pytest.approx(25e-3)
