"""The 3D rod's time-against-error benchmark runs and reports what it measured."""

import json

import pytest

from magsoft_env.bench import cable_bench


@pytest.mark.slow
def test_cable_bench_quick_runs(tmp_path, capsys):
    out = tmp_path / "b.json"
    assert cable_bench.main(["--quick", "--json", str(out)]) == 0
    text = capsys.readouterr().out
    assert "statics" in text and "frequencies" in text and "crawl" in text and "knee" in text
    data = json.loads(out.read_text())
    strip = [r for r in data["statics"] if r["rod"] == "strip"]
    assert strip and all(r["success"] for r in strip)
    assert strip[0]["tip_error_L"] < 1e-2  # N = 10, in plane: 0.64 % of L
    assert abs(data["frequencies"][0]["error"]) < 5e-3
    crawl = data["crawl"][0]
    assert crawl["strip_ok"] and crawl["chain_ok"] and crawl["strip_wall_per_s"] > 0.0


def test_cable_bench_refuses_unknown_sections():
    with pytest.raises(SystemExit):
        cable_bench.main(["--only", "x"])
