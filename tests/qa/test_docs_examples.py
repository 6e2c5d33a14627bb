"""The worked examples of docs/qa-accuracy.md are run: each ```console block's command must print every
line the block shows and exit with the code it states, so the docs cannot drift from the tool."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest
from click.testing import CliRunner
from qa_accuracy_helpers import KUBAD

from aerosurvey.cli import main

ROOT = Path(__file__).resolve().parents[2]
DOC = ROOT / "docs" / "qa-accuracy.md"
#: Where the examples' files are found by name (the docs name the file, not the folder).
DATA_DIRS = (KUBAD.parent, ROOT / "tests" / "data" / "qa")


def _examples() -> list[tuple[str, list[str], int]]:
    blocks = re.findall(r"```console\n(.*?)```", DOC.read_text(encoding="utf-8"), re.S)
    out = []
    for b in blocks:
        lines = b.strip("\n").split("\n")
        assert lines[0].startswith("$ aerosurvey "), lines[0]
        code = re.fullmatch(r"\(exit (\d)\)", lines[-1])
        assert code, f"the block of {lines[0]!r} must end with (exit N)"
        out.append((lines[0][2:], lines[1:-1], int(code.group(1))))
    return out


def _resolve(arg: str) -> str:
    if not arg.endswith((".csv", ".geojson")):
        return arg
    found = [d / arg for d in DATA_DIRS if (d / arg).is_file()]
    assert found, f"{arg}: not found in {', '.join(map(str, DATA_DIRS))}"
    return str(found[0])


EXAMPLES = _examples()


def test_the_docs_have_worked_examples() -> None:
    assert len(EXAMPLES) >= 5


@pytest.mark.parametrize("command,expected,code", EXAMPLES, ids=[f"example{i + 1}" for i in range(len(EXAMPLES))])
def test_docs_example_prints_what_the_docs_say(command: str, expected: list[str], code: int) -> None:
    args = [_resolve(a) for a in shlex.split(command)[1:]]
    res = CliRunner().invoke(main, args)
    assert res.exit_code == code, res.output
    for line in expected:
        assert line in res.stdout, f"{line!r} not printed by: {command}\n{res.stdout}"
