"""`hubero test --junit-xml FILE`: the runs' verdicts as a JUnit XML report, which CI systems
(GitLab, Jenkins, GitHub actions that read test reports) show beside their own tests.

One `testsuite` per scenario file, one `testcase` per run (its variant, or "as written"): a run
whose expectations failed, or that did not complete, is a `failure`; a file that cannot be
read or does not compile, or whose parameters a controller handed over does not take, and a
run that ended in an error (a controller or planner plugin that raised) are an `error`. Times
are wall-clock seconds, as test reports keep them. Written by the standard library's
ElementTree, whole or not at all.
"""

from __future__ import annotations

import re
import tempfile
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

from hubero_dsl.errors import InputError
from hubero_dsl.files import check_output, refuse_other_kind, write_replacing

CaseResult = Literal["pass", "fail", "error"]
# How the reports hubero writes begin: one of them may be written over, no other file
BEGINNING = b"<?xml version='1.0' encoding='utf-8'?>\n<testsuites"


# The cases of a file that never ran: no variant can be so named (not an identifier)
UNREADABLE, UNCOMPILED = "(cannot be read)", "(does not compile)"
UNFITTING = "(does not fit the controller)"  # a class handed over refuses its parameters


@dataclass(frozen=True)
class TestOutcome:
    """One run's verdict, or one file's that could not be read or does not compile."""

    __test__ = False  # a report's case, not a test for pytest to collect

    file: str
    case: str                 # the variant, "as written", UNREADABLE, UNCOMPILED or UNFITTING
    verdict: CaseResult
    message: str              # one line: how the run ended, or the error
    details: tuple[str, ...] = field(default_factory=tuple)  # the failing expectations
    seconds: float = 0.0


def check_report_path(path: Path, reads: Sequence[Path]) -> None:
    """Refuse (InputError), before anything runs, a report that could not be written (a
    file is made beside it and removed, to know) or would go over a file that is no report
    of hubero's (a scenario among them)."""
    check_output(path, reads)
    refuse_other_kind(path, BEGINNING, "a JUnit XML report of hubero test",
                      "give another --junit-xml name")
    try:
        with tempfile.NamedTemporaryFile(dir=path.parent, prefix=f".{path.name}.",
                                         suffix=".probe"):
            pass
    except OSError as exc:
        raise InputError(f"{path}: cannot be written ({exc.strerror or exc})") from None


def write_report(path: Path, outcomes: Sequence[TestOutcome]) -> Path:
    """Write the report of `outcomes`, in their order, grouped by file."""
    root = ET.Element("testsuites", _counts("hubero test", outcomes))
    for file in dict.fromkeys(o.file for o in outcomes):
        mine = [o for o in outcomes if o.file == file]
        suite = ET.SubElement(root, "testsuite", _counts(file, mine))
        for outcome in mine:
            _testcase(suite, outcome)
    ET.indent(root)
    tree = ET.ElementTree(root)
    return write_replacing(path, lambda temp: tree.write(temp, encoding="utf-8",
                                                         xml_declaration=True))


def _counts(name: str, outcomes: Sequence[TestOutcome]) -> dict[str, str]:
    return {"name": xml_text(name), "tests": str(len(outcomes)),
            "failures": str(sum(o.verdict == "fail" for o in outcomes)),
            "errors": str(sum(o.verdict == "error" for o in outcomes)),
            "time": f"{sum(o.seconds for o in outcomes):.3f}"}


def _testcase(suite: ET.Element, outcome: TestOutcome) -> None:
    case = ET.SubElement(suite, "testcase", {"classname": xml_text(outcome.file),
                                             "name": xml_text(outcome.case),
                                             "time": f"{outcome.seconds:.3f}"})
    if outcome.verdict == "pass":
        ET.SubElement(case, "system-out").text = xml_text(outcome.message)
        return
    tag = "failure" if outcome.verdict == "fail" else "error"
    problem = ET.SubElement(case, tag, {"message": xml_text(outcome.message), "type": tag})
    # a failure's text: how the run ended, then what failed; an error's: every error found
    said = list(outcome.details) if tag == "error" and outcome.details else [outcome.message,
                                                                             *outcome.details]
    problem.text = xml_text("\n".join(said))


# What XML 1.0 cannot hold, escaped or not: control characters (a plugin's message may carry
# a terminal's colour codes) and lone surrogates (a file name that is not UTF-8)
_NOT_XML = re.compile("[^\t\n\r\x20-\ud7ff\ue000-\ufffd\U00010000-\U0010ffff]")


def xml_text(text: str) -> str:
    """`text` with each character XML cannot hold written as its Python escape (`\\x1b`)."""
    return _NOT_XML.sub(lambda c: repr(c.group())[1:-1], text)
