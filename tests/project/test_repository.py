"""The repository stands alone: it cites the paper by its title, not files outside
it, and git ignores what the README's commands write."""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
TITLE = (
    "On the Adequacy of Adams-Bashforth Sampled-Data Models for Characterizing Complex "
    "Underwater-Vehicle Dynamics with Noisy Measurements"
)
OUTSIDE = re.compile(r"shared/|spec/paper\.md|DESIGN\.md")


def _texts():
    yield ROOT / "README.md"
    yield from sorted((ROOT / "docs").rglob("*.md"))
    yield from sorted((ROOT / "sampledyn").rglob("*.py"))
    yield from sorted((ROOT / "examples").rglob("*.toml"))


def test_no_reference_to_files_outside_the_repository():
    found = [
        f"{p.relative_to(ROOT)}:{n}: {line.strip()}"
        for p in _texts()
        for n, line in enumerate(p.read_text().splitlines(), 1)
        if OUTSIDE.search(line)
    ]
    assert found == []


def test_the_paper_is_cited_by_its_title():
    flat = " ".join((ROOT / "README.md").read_text().split())
    assert TITLE in flat
    assert (ROOT / "docs" / "design.md").is_file()


def _outputs_of_readme() -> set[str]:
    """Paths the README's commands write: --store and --out values, and the files
    it says a command writes."""
    text = (ROOT / "README.md").read_text()
    paths = set(re.findall(r"--(?:store|out)[ =]([\w./-]+)", text))
    paths |= set(re.findall(r"writes `([\w./-]+)`", text))
    return {p for p in paths if not p.startswith(("/", "$"))}


@pytest.mark.skipif(shutil.which("git") is None, reason="needs git")
def test_git_ignores_what_the_readme_commands_write():
    outputs = _outputs_of_readme()
    assert {"results.db", "report/"} <= outputs and any(p.startswith("out/") for p in outputs)
    for path in sorted(outputs):
        probe = path + "index.html" if path.endswith("/") else path
        res = subprocess.run(
            ["git", "check-ignore", "--no-index", "-q", probe], cwd=ROOT, capture_output=True
        )
        if res.returncode == 128:
            pytest.skip(f"not a git checkout: {res.stderr.decode().strip()}")
        assert res.returncode == 0, f"{path} (written by a README command) is not ignored"


README_LIMIT = 12_000  # characters: the front door, not the manual (the rest is in docs/)


def test_the_readme_is_a_front_door():
    text = (ROOT / "README.md").read_text()
    assert len(text) <= README_LIMIT, f"README.md has {len(text)} characters; move text to docs/"
    for command in ("pip install . && sampledyn reproduce fig7",
                    "pip install '.[test]' && pytest", 'pytest -m "not slow"'):  # fmt: skip
        assert command in text, command


def _anchor(heading: str) -> str:
    """GitHub's anchor of a Markdown heading."""
    slug = re.sub(r"[^\w\- ]", "", heading.strip().lower())
    return slug.replace(" ", "-")


def _anchors(path: Path) -> set[str]:
    return {_anchor(m) for m in re.findall(r"^#+ (.+)$", path.read_text(), re.MULTILINE)}


def test_every_relative_link_of_the_docs_resolves():
    pages = [ROOT / "README.md", ROOT / "examples" / "README.md",
             *sorted((ROOT / "docs").glob("*.md"))]  # fmt: skip
    broken = []
    for page in pages:
        for target in re.findall(r"\]\(([^)\s]+)\)", page.read_text()):
            if re.match(r"[a-z]+:", target):
                continue  # http(s), mailto
            path, _, anchor = target.partition("#")
            dest = (page.parent / path).resolve() if path else page
            if not dest.exists() or (anchor and dest.suffix == ".md"
                                     and anchor not in _anchors(dest)):  # fmt: skip
                broken.append(f"{page.relative_to(ROOT)}: {target}")
    assert not broken, broken
