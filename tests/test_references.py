"""Every source is cited by author and year, and every citation resolves.

The repository must be readable on its own: no file may point at documents
that are not in it (the source-document folder or the design notes the
project was written from), and every author-year citation in the code and
the docs must name an entry of ``docs/references.md``.
"""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
REFERENCES = ROOT / "docs" / "references.md"

# Written split so that this file does not match itself.
FORBIDDEN = ("seed" + " 00", "seeds" + "/", "DESIGN" + ".md")

_SURNAME = r"(?:[A-ZÅÄÖ][a-zà-ÿ]+(?:-[A-Z][a-zà-ÿ]+)?|controltheplant)"
# "Nowak et al. 2018", "Åström & Hägglund (2006", "Rivera, Morari & Skogestad 1986",
# "Åström's (1987)", "Nowak et al.'s (2018)"
CITATION = re.compile(
    rf"(?<![\w.-])(?P<authors>{_SURNAME}(?:(?:, {_SURNAME})* (?:&|and) {_SURNAME})?(?: et al\.)?)"
    r"(?:'s)?,? \(?(?P<year>(?:19|20)\d\d)(?![\d.])"
)
# Publishers and words that precede a year without being a citation.
NOT_AUTHORS = {"ISA", "McGraw-Hill", "Prentice", "Hall", "York", "Control"}


def _repository_files() -> list[Path]:
    out = subprocess.run(
        ["git", "ls-files", "--cached", "--others", "--exclude-standard"],
        cwd=ROOT,
        capture_output=True,
        text=True,
        check=True,
    ).stdout.split()
    return [ROOT / f for f in out if (ROOT / f).is_file()]


def _text(path: Path) -> str | None:
    try:
        return path.read_text(encoding="utf-8")
    except (UnicodeDecodeError, OSError):
        return None  # binary (PNG figures)


def _labels() -> dict[str, str]:
    """``{"Nowak et al. 2018": "nowak2018", ...}`` from docs/references.md."""
    text = REFERENCES.read_text(encoding="utf-8")
    return dict(
        (label, key)
        for key, label in re.findall(r'<a id="(\w+)"></a>\n- \*\*([^*]+)\*\*', text)
    )


def _flatten(text: str) -> str:
    """Join lines (and comment/docstring prefixes) so citations broken over lines are found."""
    return re.sub(r"\s*\n\s*(?:#|\*|//)?\s*", " ", text)


def citations(text: str) -> list[str]:
    """The author-year citations in ``text``, normalised to ``"Authors YYYY"``."""
    found = []
    for m in CITATION.finditer(_flatten(text)):
        authors = m.group("authors")
        if authors.split(",")[0].split(" ")[0] in NOT_AUTHORS:
            continue
        found.append(f"{authors} {m.group('year')}")
    return found


def test_the_citation_pattern_finds_the_forms_the_project_uses() -> None:
    text = (
        "see Nowak et al. 2018, (4a); Åström & Hägglund (2006, chapter 6);\n"
        "# Rivera, Morari &\n# Skogestad 1986 and Åström's (1987) name,"
        " Nowak et al.'s (2018) list,\n"
        "controltheplant 2024, section 2.3.6; McGraw-Hill 1995; Python 3.12"
    )
    assert citations(text) == [
        "Nowak et al. 2018",
        "Åström & Hägglund 2006",
        "Rivera, Morari & Skogestad 1986",
        "Åström 1987",
        "Nowak et al. 2018",
        "controltheplant 2024",
    ]


def test_references_have_unique_keys_sorted_by_key() -> None:
    text = REFERENCES.read_text(encoding="utf-8")
    keys = re.findall(r'<a id="(\w+)"></a>', text)
    assert len(keys) >= 15
    assert keys == sorted(keys)
    assert len(set(keys)) == len(keys)
    assert len(_labels()) == len(keys), "every key is followed by a bold author-year label"


def test_the_four_source_documents_are_listed() -> None:
    labels = _labels()
    for label in ("Nowak et al. 2018", "controltheplant 2024", "Bonde et al. 2021", "Åström 1987"):
        assert label in labels


def test_no_file_refers_to_documents_outside_the_repository() -> None:
    offenders = []
    for path in _repository_files():
        text = _text(path)
        if text is None:
            continue
        for n, line in enumerate(text.splitlines(), 1):
            low = line.lower()
            for word in FORBIDDEN:
                if word.lower() in low:
                    offenders.append(f"{path.relative_to(ROOT)}:{n}: {line.strip()[:80]}")
    assert offenders == []


@pytest.mark.parametrize("area", ["src", "docs", "README.md", "benchmarks"])
def test_every_author_year_citation_resolves_to_a_reference(area: str) -> None:
    labels = _labels()
    unresolved = []
    for path in _repository_files():
        rel = path.relative_to(ROOT)
        if not str(rel).startswith(area) or path == REFERENCES:
            continue
        text = _text(path)
        if text is None:
            continue
        for cite in citations(text):
            if cite not in labels:
                unresolved.append(f"{rel}: {cite}")
    assert unresolved == []
