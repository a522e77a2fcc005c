"""Every relative link in the README and in docs/ leads somewhere: the file exists, and a
``#section`` of a Markdown file names one of its headings (GitHub's anchors)."""
from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
LINK = re.compile(r"\]\(([^)\s]+)\)")


def anchor(heading: str) -> str:
    """GitHub's anchor for a heading: lower case, punctuation dropped, spaces as hyphens."""
    text = re.sub(r"[`*_]", "", heading.strip().lower())
    return re.sub(r"[^\w\- ]", "", text).replace(" ", "-")


def anchors(page: Path) -> set[str]:
    text = re.sub(r"```.*?```", "", page.read_text(encoding="utf-8"), flags=re.S)    # no headings in code
    return {anchor(line.lstrip("#")) for line in text.splitlines() if re.match(r"#{1,6} ", line)}


def relative_links(page: Path) -> list[str]:
    return [link for link in LINK.findall(page.read_text(encoding="utf-8"))
            if not re.match(r"[a-z]+:", link) and not link.startswith("#")]


def test_the_anchor_rule():
    assert anchor("Feet that stay planted") == "feet-that-stay-planted"
    assert anchor("MoGlow anchored: how it came to this") == "moglow-anchored-how-it-came-to-this"
    assert anchor("The VAE-LSTM's bones") == "the-vae-lstms-bones"


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.relative_to(ROOT).as_posix())
def test_relative_links_lead_somewhere(page):
    for link in relative_links(page):
        target, _, section = link.partition("#")
        path = (page.parent / target).resolve()
        assert path.exists(), f"{page.name}: {link} names no file"
        if section and path.suffix == ".md":
            assert section in anchors(path), f"{page.name}: {link}: {path.name} has no heading '{section}'"


def test_the_feet_record_is_linked_from_the_readme():
    assert "docs/feet.md" in (ROOT / "README.md").read_text(encoding="utf-8")
