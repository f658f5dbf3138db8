"""The documentation under docs/ stands on its own: every "docs/<page>.md section N" cited in the
repository lands on a numbered section of that page, relative links and #anchors resolve, and the
files and test nodes the pages point at exist."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
PAGES = sorted(DOCS.glob("*.md"))
# Scanned for citations of numbered sections.
SOURCES = [
    *ROOT.glob("README.md"),
    *(ROOT / "ffsm_pin").rglob("*.py"),
    *(ROOT / "ffsm_pin").rglob("*.toml"),
    *(ROOT / "tests").rglob("*.py"),
    *(ROOT / "benchmarks").rglob("*.py"),
    *(ROOT / "benchmarks").rglob("*.md"),
    *PAGES,
]
# Pages and paths written on other branches (links to them are allowed to dangle until merged).
PENDING: set[str] = set()

CITATION = re.compile(r"docs/(\w+)\.md,? sections? (\d+)(?:\s*-\s*(\d+))?")
LINK = re.compile(r"\]\(([^)\s]+)\)")
CODE_PATH = re.compile(r"`((?:ffsm_pin|tests|benchmarks|docs|urdf)/[\w/.\-]+)`")
TEST_REF = re.compile(r"`(tests/[\w/]+\.py)?(?:::(\w+))?`")


def slug(heading: str) -> str:
    """GitHub's anchor for a heading: lower case, punctuation dropped, spaces to dashes."""
    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


def headings(page: Path) -> list[str]:
    return [m.group(1) for m in re.finditer(r"^#+ (.+)$", page.read_text(), re.M)]


def numbered_sections(page: Path) -> set[int]:
    return {int(m.group(1)) for h in headings(page) if (m := re.match(r"(\d+)\. ", h))}


def pending(rel: str) -> bool:
    return any(rel == p or rel.startswith(p + "/") for p in PENDING)


def test_every_cited_section_exists():
    cited = []
    for src in SOURCES:
        for m in CITATION.finditer(src.read_text(encoding="utf-8")):
            first = int(m.group(2))
            last = int(m.group(3) or first)
            cited += [(src, m.group(1), n) for n in range(first, last + 1)]
    assert len(cited) > 30  # the code really cites the pages (a broken regex would pass vacuously)
    missing = []
    for src, page, n in cited:
        path = DOCS / f"{page}.md"
        if not path.is_file() or n not in numbered_sections(path):
            missing.append(f"{src.relative_to(ROOT)}: docs/{page}.md section {n}")
    assert not missing, missing


@pytest.mark.parametrize("page", ["model", "spatial"])
def test_numbered_pages_have_sections_1_to_7(page):
    assert numbered_sections(DOCS / f"{page}.md") == set(range(1, 8))


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.name)
def test_links_and_anchors_resolve(page):
    bad = []
    for m in LINK.finditer(page.read_text()):
        target = m.group(1)
        if re.match(r"[a-z]+:", target):  # http(s), mailto
            continue
        path, _, anchor = target.partition("#")
        dest = (page.parent / path).resolve() if path else page
        rel = dest.relative_to(ROOT).as_posix() if dest.is_relative_to(ROOT) else str(dest)
        if not dest.exists():
            if not pending(rel):
                bad.append(f"missing file {target}")
            continue
        if anchor and dest.suffix == ".md" and anchor not in {slug(h) for h in headings(dest)}:
            bad.append(f"missing anchor {target}")
    assert not bad, bad


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.name)
def test_code_paths_and_test_nodes_exist(page):
    text = page.read_text()
    bad = [
        rel
        for rel in CODE_PATH.findall(text)
        if not (ROOT / rel).exists() and not pending(rel.rstrip("/"))
    ]
    current = None  # "::name" refers to the last test file named before it
    for m in TEST_REF.finditer(text):
        file, name = m.groups()
        if file:
            current = file
        if name and current and not re.search(rf"def {name}\b", (ROOT / current).read_text()):
            bad.append(f"{current}::{name}")
    assert not bad, bad


@pytest.mark.parametrize("page", [*PAGES, ROOT / "README.md"], ids=lambda p: p.name)
def test_tables_are_not_cut_by_a_blank_line(page):
    """A table row after a blank line that follows a table (and is not the header of a new
    table) is a table cut in two: markdown renders its second part as a paragraph of pipes."""
    lines = page.read_text().split("\n")
    header_rule = re.compile(r"^\|[\s:|-]*\|\s*$")
    cut = [
        i + 1
        for i in range(2, len(lines) - 1)
        if lines[i].startswith("|")
        and not lines[i - 1].strip()
        and lines[i - 2].startswith("|")
        and not header_rule.match(lines[i + 1])
    ]
    assert cut == [], f"{page.name}: table rows after a blank line at lines {cut}"
