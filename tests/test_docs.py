"""The documentation: a short README, no issue numbers or history in what users read, every page
reachable, the Python guide's example runs."""

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
USER_PAGES = [ROOT / "README.md", *sorted(p for p in DOCS.rglob("*.md") if "_build" not in p.parts)]
HISTORY = re.compile(r"\bissues?\s*#?\d|\bthe issue'?s?\b|\bbefore the rewrite\b|\bthe old report\b", re.IGNORECASE)


def test_readme_is_a_front_page():
    assert len((ROOT / "README.md").read_text().splitlines()) <= 250


@pytest.mark.parametrize("page", USER_PAGES, ids=lambda p: str(p.relative_to(ROOT)))
def test_no_issue_numbers_or_history_in_user_pages(page):
    text = page.read_text()
    hits = [m.group(0) for m in HISTORY.finditer(text)]
    assert not hits, f"{page.relative_to(ROOT)}: {hits} (history belongs in CHANGELOG.md)"


def test_guide_pages_are_found_by_the_glob_and_have_one_title():
    index = (DOCS / "index.md").read_text()
    assert "guide/*" in index and ":glob:" in index
    for page in sorted((DOCS / "guide").glob("*.md")):
        lines = page.read_text().splitlines()
        assert lines[0].startswith("# "), page.name
        fenced = False
        titles = 0
        for line in lines:
            if line.startswith("```"):
                fenced = not fenced
            elif not fenced and line.startswith("# "):
                titles += 1
        assert titles == 1, page.name


def _python_blocks(page: Path) -> list[str]:
    return re.findall(r"```python\n(.*?)```", page.read_text(), flags=re.DOTALL)


@pytest.mark.slow
def test_python_guide_example_runs():
    blocks = _python_blocks(DOCS / "guide" / "python.md") + _python_blocks(ROOT / "README.md")
    assert blocks
    for code in blocks:
        exec(compile(code, "<docs>", "exec"), {})
