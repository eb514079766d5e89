"""The README and docs/: every relative link (README.md and docs/*.md) reaches a file of the
repository, and every anchor a heading of the page it names; the README's first screen holds the
two commands, the second exactly as .ci/run runs it."""
from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
FIRST_SCREEN = 60   # lines
LINK = re.compile(r"(?<!!)\[[^\]]*\]\(([^)\s]+)\)|!\[[^\]]*\]\(([^)\s]+)\)")
FENCE = re.compile(r"^```.*?^```", re.M | re.S)


def slug(heading: str) -> str:
    """GitHub's anchor of a heading: lower case, markup and punctuation dropped (not - and _),
    spaces to -."""
    text = re.sub(r"[`*]|\[([^\]]*)\]\([^)]*\)", r"\1", heading.strip()).lower()
    return re.sub(r"[^\w\- ]", "", text).replace(" ", "-")


def anchors(page: Path) -> set[str]:
    out, seen = set(), {}
    for line in FENCE.sub("", page.read_text()).splitlines():
        if m := re.match(r"#{1,6}\s+(.*)", line):
            s = slug(m.group(1))
            n = seen.get(s, 0)
            seen[s] = n + 1
            out.add(s if n == 0 else f"{s}-{n}")
    return out


def broken_links(page: Path, root: Path = ROOT) -> list[str]:
    """The relative links of ``page`` (outside code blocks) that reach no file under ``root``, or
    an anchor that is no heading of the page they name."""
    bad = []
    for m in LINK.finditer(FENCE.sub("", page.read_text())):
        target = m.group(1) or m.group(2)
        if re.match(r"[a-z][a-z0-9+.-]*:", target):        # http:, https:, mailto:
            continue
        path, _, anchor = target.partition("#")
        dest = (page.parent / path).resolve() if path else page
        if not dest.is_relative_to(root.resolve()) or not dest.exists():
            bad.append(f"{page.name}: {target} (no such file)")
        elif anchor and (dest.suffix != ".md" or anchor not in anchors(dest)):
            bad.append(f"{page.name}: {target} (no such heading)")
    return bad


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.name)
def test_every_link_reaches_its_file_and_heading(page):
    assert broken_links(page) == []


def test_the_link_check_can_fail(tmp_path):
    (tmp_path / "docs").mkdir()
    (tmp_path / "docs" / "a.md").write_text("# A page\n\n## Which `shaft` coupling?\n")
    page = tmp_path / "README.md"
    page.write_text("[ok](docs/a.md) [ok](docs/a.md#which-shaft-coupling) [ok](#top) [web](https://x.org/y)\n"
                    "# Top\n[gone](docs/b.md) [bad anchor](docs/a.md#nope) [outside](../etc.md)\n"
                    "```\n[in code](docs/none.md)\n```\n")
    assert broken_links(page, tmp_path) == ["README.md: docs/b.md (no such file)",
                                            "README.md: docs/a.md#nope (no such heading)",
                                            "README.md: ../etc.md (no such file)"]


def test_the_readme_first_screen_has_the_two_commands_ci_runs():
    first = "\n".join((ROOT / "README.md").read_text().splitlines()[:FIRST_SCREEN])
    ci = [line for line in (ROOT / ".ci" / "run").read_text().splitlines() if line.startswith("python3 -m venv")]
    assert len(ci) == 1 and ci[0] in first.splitlines()       # the test command, verbatim
    assert ("python3 -m venv .venv && .venv/bin/pip install -q -e . && .venv/bin/spurdiff run vehicle-cornering"
            in first.splitlines())
    assert "docs/" in first                                     # and where to go next
