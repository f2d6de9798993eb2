"""The language documents hold true: their examples check, and every code is catalogued.

- The example of the language contract (`../shared/LANGUAGE.md`, "An example"), with its map
  pointed at the project's living room, checks without errors. Skipped without `../shared`.
- Every ```hub block of `docs/language.md` is a whole scenario that checks clean.
- Every diagnostic code the package can emit has a line in the reference's catalogue.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from hubero_dsl.lang.symbols import reserved_words
from hubero_dsl.pipeline import check_source

REPO_ROOT = Path(__file__).resolve().parents[2]
SHARED = REPO_ROOT / ".." / "shared"
REFERENCE = REPO_ROOT / "docs" / "language.md"


def _blocks(markdown: str, language: str) -> list[str]:
    return re.findall(rf"^```{language}\n(.*?)^```$", markdown, flags=re.M | re.S)


def _reference_blocks() -> list[str]:
    return _blocks(REFERENCE.read_text(encoding="utf-8"), "hub")


@pytest.mark.skipif(not (SHARED / "LANGUAGE.md").is_file(), reason="../shared is not there")
def test_the_contract_example_checks() -> None:
    contract = (SHARED / "LANGUAGE.md").read_text(encoding="utf-8")
    section = contract.split("## An example", 1)[1]
    (example,) = _blocks(section, "")[:1]
    assert example.startswith("scenario")
    # Checked as if it were a file in scenarios/, next to which ../maps/ is the project's maps.
    result = check_source(example, str(REPO_ROOT / "scenarios" / "contract_example.hub"))
    assert result.errors == []
    assert [(d.code, d.message) for d in result.warnings] == [
        ("W501", "place 'table' is never used")]
    assert result.program is not None


def test_the_reference_has_examples() -> None:
    assert len(_reference_blocks()) >= 5


@pytest.mark.parametrize("index", range(len(_reference_blocks())))
def test_every_reference_example_checks_clean(index: int) -> None:
    block = _reference_blocks()[index]
    result = check_source(block, str(REFERENCE))
    assert [(d.code, d.span and d.span.line, d.message) for d in result.diagnostics] == []


def test_every_code_is_in_the_catalogue() -> None:
    package = REPO_ROOT / "hubero_dsl"
    emitted = {code for path in package.rglob("*.py")
               for code in re.findall(r'"([EW]\d{3})"', path.read_text(encoding="utf-8"))}
    catalogue = set(re.findall(r"^\| `([EW]\d{3})` \|", REFERENCE.read_text(encoding="utf-8"),
                               flags=re.M))
    assert emitted <= catalogue, sorted(emitted - catalogue)


def test_every_code_in_the_catalogue_has_a_golden_example() -> None:
    # the reference says so of every code `hubero check` reports (a few the graph analysis
    # alone reports are "reported as E1xx by `hubero check`")
    catalogue = {code for code, meaning in re.findall(r"^\| `([EW]\d{3})` \|(.*)$",
                                                       REFERENCE.read_text(encoding="utf-8"),
                                                       flags=re.M)
                 if "by `hubero check`" not in meaning}
    golden = REPO_ROOT / "tests" / "cases" / "diagnostics"
    shown = {code for path in golden.glob("*.txt")
             for code in re.findall(r"^(?:error|warning)\[([EW]\d{3})\]",
                                    path.read_text(encoding="utf-8"), flags=re.M)}
    assert catalogue <= shown, sorted(catalogue - shown)


def test_the_reserved_words_are_listed() -> None:
    section = REFERENCE.read_text(encoding="utf-8").split("## Reserved words", 1)[1]
    (listing,) = _blocks(section, "")[:1]
    assert set(listing.split()) == reserved_words()


ROBOTS = REPO_ROOT / "docs" / "robots.md"


def test_the_robots_page_examples_check_clean() -> None:
    blocks = [b for b in _blocks(ROBOTS.read_text(encoding="utf-8"), "hub")
              if b.lstrip().startswith("scenario")]
    assert blocks
    for block in blocks:
        result = check_source(block, str(ROBOTS))
        assert not result.diagnostics, [d.message for d in result.diagnostics]


def test_every_code_the_docs_name_exists() -> None:
    """No page shows a code hubero does not emit (and the catalogue lists no stale one)."""
    package = REPO_ROOT / "hubero_dsl"
    emitted = {code for path in package.rglob("*.py")
               for code in re.findall(r'"([EW]\d{3})"', path.read_text(encoding="utf-8"))}
    pages = [*(REPO_ROOT / "docs").glob("*.md"), REPO_ROOT / "README.md"]
    named = {(page.name, code) for page in pages
             for code in re.findall(r"\b([EW]\d{3})\b", page.read_text(encoding="utf-8"))}
    assert sorted((page, code) for page, code in named if code not in emitted) == []


@pytest.mark.parametrize("index", range(len(_reference_blocks())))
def test_every_reference_example_runs_and_its_expectations_hold(index: int) -> None:
    """The examples of docs/language.md (crowds, flows, groups, robots among them) are what
    `hubero test` would pass: every variant completes and every `expect` holds."""
    from hubero_dsl.pipeline import compile_source
    from hubero_dsl.sim.loop import run_program
    from hubero_dsl.sim.simulation import Simulation

    program = compile_source(_reference_blocks()[index], str(REFERENCE))
    for variant in list(program.variants) or [None]:
        result = run_program(Simulation(program, variant=variant))
        assert result.succeeded, (program.title, variant, result.reason,
                                  [e.text for e in result.expectations if not e.held])
