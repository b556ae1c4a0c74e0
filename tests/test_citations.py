"""References a reader can follow: the code cites the model by a section of docs/model.md that
exists, never a file outside the repository or an issue."""

import pathlib
import re

import pytest

ROOT = pathlib.Path(__file__).resolve().parent.parent
SOURCES = sorted(
    path
    for folder in ("porous_weathering", "tests", "benchmarks", "node_groups", "sample_blends", "scripts")
    for path in (ROOT / folder).rglob("*")
    if path.suffix in (".py", ".osl", ".sh") and "__pycache__" not in path.parts
)
SECTION = re.compile(r"docs/model\.md §(\d+(?:\.\d+)?)")


def model_sections():
    text = (ROOT / "docs" / "model.md").read_text()
    return set(re.findall(r"^#{2,3} (\d+(?:\.\d+)?)\.? ", text, re.M))


def test_model_md_has_the_numbered_sections_the_code_cites():
    assert {"1", "2", "3", "4", "5", "6", "4.2", "6.3"} <= model_sections()


@pytest.mark.parametrize("path", SOURCES, ids=lambda path: str(path.relative_to(ROOT)))
def test_citations_point_into_the_repository(path):
    if path == pathlib.Path(__file__):
        return
    text = path.read_text()
    assert not re.search(r"\bSPEC\b", text), "cite docs/model.md §N, not SPEC (outside the repository)"
    assert not re.search(r"\bissues? \d+|\(issue \d+", text, re.I), "cite what is checked or docs/, not an issue"
    missing = set(SECTION.findall(text)) - model_sections()
    assert not missing, f"docs/model.md has no section {sorted(missing)}"
