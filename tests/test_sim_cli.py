"""``magsoft crosscheck`` end to end with a tiny budget."""

from __future__ import annotations

import pytest

pytest.importorskip("magsoft_env.theory")
from magsoft_env.cli import main  # noqa: E402


def test_crosscheck_runs_end_to_end(tmp_path, capsys):
    rc = main(["crosscheck", "fig3a_L20", "--segments", "8", "16", "--steps", "4", "--out", str(tmp_path)])
    out = capsys.readouterr().out
    assert rc == 0, out
    lines = [ln for ln in out.splitlines() if ln.startswith("fig3a_L20")]
    assert len(lines) == 2
    err8, err16 = (float(ln.split()[2]) for ln in lines)
    assert err16 < err8 < 5.0  # percent of L; converges with segments
    assert (tmp_path / "crosscheck.csv").read_text().count("\n") == 3
    assert (tmp_path / "crosscheck_fig3a_L20.png").stat().st_size > 0


def test_crosscheck_rejects_bad_input(capsys):
    assert main(["crosscheck", "fig3a_L2O", "--segments", "8"]) == 2
    assert "fig3a_L20" in capsys.readouterr().err  # suggests the closest name
    assert main(["crosscheck", "fig3a_L20", "--segments", "1"]) == 2
    assert "--segments" in capsys.readouterr().err
