"""The repository stands alone: no file in it refers to a path outside it.

A clone in an empty folder must pass `make demo` and `make test` (`.ci/run` runs them on such a
copy). This test catches the references that would make that fail, or that send a reader of the
code to a file they do not have: a path into a sibling folder (the shared docs, papers or reference
folder beside the repository), or a machine's own folders (root's, the workplace's, a home folder).
Sources are cited by their title. This file names no such path itself: its examples are built from
pieces, so the check holds for it like for every other file.
"""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]

#: Paths that lead out of the repository.
SIBLING = "shared"
OUTSIDE = re.compile(r"(\.\./" + SIBLING + r"\b|\b" + SIBLING + r"/(papers|reference|docs)\b|(?<![\w.])/(root|work|home)/\w)")


def _repository_files() -> list[Path]:
    try:
        out = subprocess.run(["git", "ls-files", "--cached", "--others", "--exclude-standard"], cwd=REPO,
                             capture_output=True, text=True, check=True).stdout.splitlines()
        return [REPO / f for f in out if (REPO / f).is_file()]
    except (OSError, subprocess.CalledProcessError):  # not a git checkout: every file but the local venv
        skip = {".venv", ".git", "out", "build", ".pytest_cache", ".hypothesis"}
        return [p for p in REPO.rglob("*") if p.is_file() and not skip & set(p.relative_to(REPO).parts)]


def _text(path: Path) -> str | None:
    data = path.read_bytes()
    if b"\0" in data[:8192]:
        return None  # binary (logs, images)
    return data.decode("utf-8", errors="replace")


def test_no_file_refers_to_a_path_outside_the_repository() -> None:
    found = []
    files = _repository_files()
    assert len(files) > 100, f"only {len(files)} files found under {REPO}"
    for path in files:
        text = _text(path)
        if text is None:
            continue
        for n, line in enumerate(text.splitlines(), 1):
            if OUTSIDE.search(line):
                found.append(f"{path.relative_to(REPO)}:{n}: {line.strip()[:120]}")
    assert not found, "paths outside the repository:\n" + "\n".join(found)


def test_the_pattern_finds_what_it_is_meant_to() -> None:
    sep = "/"
    for bad in (f"see ..{sep}{SIBLING}{sep}docs/x.md", f"{SIBLING}{sep}papers/000.txt", f'Path("{sep}root{sep}sitl/bin")',
                f"{sep}work{sep}main/src"):
        assert OUTSIDE.search(bad), bad
    for fine in ("tests/data/reference/x.csv", "shared by the format tests", "a/root/b", "src/aerosurvey/work/x"):
        assert not OUTSIDE.search(fine), fine


def test_reference_tables_are_in_the_repository() -> None:
    ref = REPO / "tests" / "data" / "reference"
    for name in ("asprs2014_checkpoint_counts.csv", "kubad_abad_gcp_residuals.csv", "bayes_obratan.csv", "cameras_from_sources.csv"):
        assert (ref / name).is_file(), name
        assert name in (ref / "README.md").read_text(encoding="utf-8"), f"{name} has no note in tests/data/reference/README.md"
