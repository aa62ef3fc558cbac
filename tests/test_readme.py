"""README.md keeps its promises: its Quick start runs and crawls, every docs page is linked, it stays short."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
MAX_LINES = 160
MIN_CRAWL = 1e-3  # m: a crawl a reader sees in the numbers the Quick start prints


def _section(text: str, title: str) -> str:
    """The body of the ``## title`` section (up to the next ``## `` heading)."""
    m = re.search(rf"^## {re.escape(title)}\s*$(.*?)(?=^## |\Z)", text, re.M | re.S)
    assert m, f"README.md has no '## {title}' section"
    return m.group(1)


def _python_blocks(text: str) -> list[str]:
    return re.findall(r"^```python\n(.*?)^```", text, re.M | re.S)


def test_quick_start_runs_and_its_robot_crawls(tmp_path, monkeypatch):
    from magsoft_env.sim.gait import GaitResult

    blocks = _python_blocks(_section(README.read_text(), "Quick start"))
    assert blocks, "the Quick start has no python block"
    monkeypatch.chdir(tmp_path)  # the files it writes land here
    namespace: dict = {"__name__": "__readme__"}
    for code in blocks:
        exec(compile(code, str(README), "exec"), namespace)
    gaits = [v for v in namespace.values() if isinstance(v, GaitResult)]
    assert gaits, "the Quick start runs no gait (no GaitResult among its names)"
    for gait in gaits:
        assert gait.success, gait.message
        assert abs(gait.displacement) >= MIN_CRAWL, (
            f"the Quick start's robot moves {gait.displacement * 1e3:.3g} mm, not a visible crawl "
            f"(>= {MIN_CRAWL * 1e3:g} mm)"
        )
        assert gait.direction in ("left", "right")
    for written in tmp_path.iterdir():  # a robot file is a recipe, not samples
        assert written.stat().st_size < 10_000, f"{written.name} is {written.stat().st_size} bytes"


def test_every_docs_page_is_linked():
    text = README.read_text()
    links = set(re.findall(r"\]\(([^)#\s]+)", text))
    pages = sorted(p.relative_to(ROOT).as_posix() for p in (ROOT / "docs").glob("*.md"))
    assert pages
    missing = [p for p in pages if p not in links]
    assert not missing, f"README.md does not link {missing}"
    broken = [link for link in links if "://" not in link and not (ROOT / link).exists()]
    assert not broken, f"README.md links files that do not exist: {broken}"


def test_readme_is_short():
    n = len(README.read_text().splitlines())
    assert n <= MAX_LINES, f"README.md has {n} lines; at most {MAX_LINES} (details go to docs/)"


@pytest.mark.parametrize("title", ["Two commands", "Quick start", "Citing", "Licence"])
def test_readme_has_the_newcomer_sections(title):
    assert _section(README.read_text(), title).strip()


def test_test_command_is_what_ci_runs():
    body = _section(README.read_text(), "Two commands")
    commands = re.findall(r"^```bash\n(.*?)^```", body, re.M | re.S)
    test_cmd = next(c.strip() for c in commands if "pytest" in c)
    ci = [line.strip() for line in (ROOT / ".ci" / "run").read_text().splitlines()
          if line.strip().startswith("python")]
    assert [part.strip() for part in test_cmd.split("&&")] == [line.replace(" --quiet", "") for line in ci]


_NARRATIVE = re.compile(
    r"\bissues? \d+|\bissue-\d+|\bthis (?:VM|machine|\d-core machine)\b|\bdevelopment (?:VM|machine)\b"
    r"|\b(?:founding|last|this|previous|next|earlier|later) sessions?\b|versionchanged",
    re.I,
)


def test_the_project_speaks_of_itself():
    """No issue numbers, no 'this VM', no sessions, no versionchanged history: that lives in CHANGELOG.md."""
    files = [README, *sorted((ROOT / "docs").glob("*.md")), *sorted((ROOT / "magsoft_env").rglob("*.py"))]
    hits = {}
    for f in files:
        for i, line in enumerate(f.read_text().splitlines(), 1):
            if _NARRATIVE.search(line):
                hits.setdefault(f.relative_to(ROOT).as_posix(), []).append(f"{i}: {line.strip()[:80]}")
    bad = [f"{name}:{hit}" for name, lines in hits.items() for hit in lines]
    assert not bad, "narrative or history outside CHANGELOG.md:\n" + "\n".join(bad)
