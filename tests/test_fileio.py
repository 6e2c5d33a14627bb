"""Output folders: staged, swapped in whole, the old one kept until the swap succeeds."""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner

from aerosurvey.cli import main
from aerosurvey.errors import InputError
from aerosurvey.fileio import LISTING, atomic_write_text, staged_directory

LOG = Path(__file__).resolve().parent / "data" / "sitl_copter_survey.bin"


def _write(outdir: Path, files: dict[str, str]) -> None:
    with staged_directory(outdir) as stage:
        for name, text in files.items():
            atomic_write_text(stage / name, text)


def _contents(folder: Path) -> dict[str, str]:
    return {p.relative_to(folder).as_posix(): p.read_text() for p in sorted(folder.rglob("*")) if p.is_file()}


def _hidden_leftovers(parent: Path) -> list[str]:
    return sorted(p.name for p in parent.iterdir() if p.name.startswith("."))


OLD = {"mission.plan": "old plan", "plan.kml": "old kml", "preview.svg": "old svg", "sortie-03.plan": "old sortie 3",
       "sub/deep.txt": "old deep"}
NEW = {"mission.plan": "new plan", "plan.kml": "new kml", "preview.svg": "new svg"}


def test_a_new_folder_gets_the_files_and_their_list(tmp_path: Path) -> None:
    _write(tmp_path / "out", OLD)
    got = _contents(tmp_path / "out")
    assert {k: v for k, v in got.items() if k != LISTING} == OLD
    listed = [ln for ln in got[LISTING].splitlines() if not ln.startswith("#")]
    assert listed == sorted(OLD)
    assert _hidden_leftovers(tmp_path) == []


def test_the_folder_is_replaced_whole(tmp_path: Path) -> None:
    _write(tmp_path / "out", OLD)
    _write(tmp_path / "out", NEW)
    got = _contents(tmp_path / "out")
    assert {k: v for k, v in got.items() if k != LISTING} == NEW  # no sortie-03.plan of the earlier plan
    assert _hidden_leftovers(tmp_path) == []


def test_an_error_while_writing_leaves_the_old_folder(tmp_path: Path) -> None:
    _write(tmp_path / "out", OLD)
    before = _contents(tmp_path / "out")
    with pytest.raises(RuntimeError), staged_directory(tmp_path / "out") as stage:
        atomic_write_text(stage / "mission.plan", "half")
        raise RuntimeError("boom")
    assert _contents(tmp_path / "out") == before and _hidden_leftovers(tmp_path) == []


def _failing(monkeypatch: pytest.MonkeyPatch, fail_on: set[int]) -> list[tuple[str, str]]:
    """os.replace and os.rename fail (EACCES) on the given calls (1-based, counted together)."""
    calls: list[tuple[str, str]] = []
    real_replace, real_rename = os.replace, os.rename

    def make(real: Callable[..., None]) -> Callable[..., None]:
        def f(src: str | os.PathLike[str], dst: str | os.PathLike[str], *a: Any, **k: Any) -> None:
            calls.append((str(src), str(dst)))
            if len(calls) in fail_on:
                raise PermissionError(13, "Permission denied", str(dst))
            real(src, dst, *a, **k)
        return f

    monkeypatch.setattr(os, "replace", make(real_replace))
    monkeypatch.setattr(os, "rename", make(real_rename))
    return calls


@pytest.mark.parametrize("fail_on", [{1}, {2}], ids=["old-to-backup", "staged-to-target"])
def test_a_failing_rename_leaves_the_old_folder_intact_and_complete(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                                    fail_on: set[int]) -> None:
    _write(tmp_path / "out", OLD)
    before = _contents(tmp_path / "out")
    with pytest.raises(InputError) as exc, staged_directory(tmp_path / "out") as stage:
        for name, text in NEW.items():
            atomic_write_text(stage / name, text)
        calls = _failing(monkeypatch, fail_on)  # from here on: the swap's renames
    monkeypatch.undo()
    msg = str(exc.value)
    assert "'" + str(tmp_path / "out") + "'" in msg and "left as it was" in msg and "\n" not in msg
    assert _contents(tmp_path / "out") == before
    assert _hidden_leftovers(tmp_path) == []  # neither the staged nor the backup folder stays
    assert len(calls) >= max(fail_on)


def test_when_the_old_folder_cannot_be_put_back_the_error_says_where_it_is(tmp_path: Path,
                                                                           monkeypatch: pytest.MonkeyPatch) -> None:
    _write(tmp_path / "out", OLD)
    before = _contents(tmp_path / "out")
    with pytest.raises(InputError) as exc, staged_directory(tmp_path / "out") as stage:
        atomic_write_text(stage / "mission.plan", "new")
        _failing(monkeypatch, {2, 3})  # staged -> target fails, and so does backup -> target
    monkeypatch.undo()
    backup = Path(str(exc.value).split("previous contents are in '")[1].rstrip("'"))
    assert backup.parent == tmp_path and _contents(backup) == before


def test_a_folder_with_files_no_run_wrote_is_refused_before_any_work(tmp_path: Path) -> None:
    _write(tmp_path / "out", NEW)
    (tmp_path / "out" / "DSC00001.JPG").write_text("a photo")
    before = _contents(tmp_path / "out")
    ran = []
    with pytest.raises(InputError, match=r"holds 1 file\(s\) aerosurvey did not write there \(DSC00001.JPG\)"), \
            staged_directory(tmp_path / "out"):
        ran.append(1)
    assert ran == [] and _contents(tmp_path / "out") == before and _hidden_leftovers(tmp_path) == []


def test_a_folder_of_an_older_version_is_replaced_only_when_nothing_else_is_in_it(tmp_path: Path) -> None:
    out = tmp_path / "out"
    out.mkdir()
    for name, text in NEW.items():  # no listing: written before there was one
        (out / name).write_text("older " + text)
    _write(out, NEW)
    assert {k: v for k, v in _contents(out).items() if k != LISTING} == NEW
    (out / LISTING).unlink()
    (out / "flight.BIN").write_text("the log")
    before = _contents(out)
    with pytest.raises(InputError, match="flight.BIN"):
        _write(out, NEW)
    assert _contents(out) == before and _hidden_leftovers(tmp_path) == []


def test_files_written_into_the_folder_while_the_command_ran_stop_the_swap(tmp_path: Path) -> None:
    _write(tmp_path / "out", NEW)
    with pytest.raises(InputError, match="tagged/A.JPG"), staged_directory(tmp_path / "out") as stage:
        atomic_write_text(stage / "events.csv", "x")
        atomic_write_text(tmp_path / "out" / "tagged" / "A.JPG", "a copy")
    assert (tmp_path / "out" / "tagged" / "A.JPG").read_text() == "a copy"


def test_a_target_that_is_a_file(tmp_path: Path) -> None:
    (tmp_path / "out").write_text("not a folder")
    with pytest.raises(InputError, match=r"output folder '.*out' is a file, not a folder"):
        _write(tmp_path / "out", NEW)
    assert (tmp_path / "out").read_text() == "not a folder"


def test_a_parent_that_is_a_file(tmp_path: Path) -> None:
    (tmp_path / "p").write_text("a file")
    with pytest.raises(InputError, match=r"'.*p/q/out': '.*p' is a file, not a folder"):
        _write(tmp_path / "p" / "q" / "out", NEW)


def test_a_parent_that_cannot_be_written(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import tempfile

    def denied(*a: object, **k: object) -> str:
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(tempfile, "mkdtemp", denied)  # tests may run as root, which chmod does not stop
    with pytest.raises(InputError, match=r"cannot write in '.*' \(Permission denied\)"):
        _write(tmp_path / "out", NEW)
    monkeypatch.undo()
    # a parent that cannot be made at all (/proc takes no new folders)
    with pytest.raises(InputError, match="cannot make its parent folder"):
        _write(Path("/proc/aerosurvey-test/out"), NEW)


def test_the_current_folder_is_not_replaced(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / "work").mkdir()
    monkeypatch.chdir(tmp_path / "work")
    with pytest.raises(InputError, match="holds the current folder"):
        _write(Path("."), NEW)
    with pytest.raises(InputError, match="holds the current folder"):
        _write(tmp_path, NEW)


def _write_merged(outdir: Path, files: dict[str, str]) -> None:
    with staged_directory(outdir, merge=True) as stage:
        for name, text in files.items():
            atomic_write_text(stage / name, text)


def _listing(folder: Path) -> list[str]:
    return [ln for ln in (folder / LISTING).read_text().splitlines() if not ln.startswith("#")]


def test_merge_keeps_the_files_the_run_does_not_write(tmp_path: Path) -> None:
    out = tmp_path / "plan"
    _write(out, OLD)
    (out / "notes.txt").write_text("the user's")
    _write_merged(out, {"plan.kml": "gcp kml", "control_points.csv": "gcp"})
    got = _contents(out)
    assert {k: v for k, v in got.items() if k != LISTING} == {**OLD, "notes.txt": "the user's", "plan.kml": "gcp kml",
                                                              "control_points.csv": "gcp"}
    assert _listing(out) == sorted({*OLD, "control_points.csv"})  # notes.txt is still not aerosurvey's
    assert _hidden_leftovers(tmp_path) == []


def test_merge_with_a_failing_rename_leaves_the_old_folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    out = tmp_path / "plan"
    _write(out, OLD)
    before = _contents(out)
    with pytest.raises(InputError, match="left as it was"), staged_directory(out, merge=True) as stage:
        atomic_write_text(stage / "control_points.csv", "gcp")
        _failing(monkeypatch, {2})
    monkeypatch.undo()
    assert _contents(out) == before and _hidden_leftovers(tmp_path) == []


# --- the commands -----------------------------------------------------------------------


def test_plan_under_a_file_is_one_line(tmp_path: Path, spec_factory) -> None:  # type: ignore[no-untyped-def]
    spec = spec_factory({})
    (tmp_path / "f").write_text("x")
    res = CliRunner().invoke(main, ["plan", str(spec), "-o", str(tmp_path / "f" / "plan")])
    assert res.exit_code == 2 and len(res.output.strip().splitlines()) == 1, res.output
    assert f"output folder '{tmp_path / 'f' / 'plan'}': '{tmp_path / 'f'}' is a file, not a folder" in res.output


def test_log_ingest_into_the_images_folder_is_refused_and_wipes_nothing(tmp_path: Path) -> None:
    img = tmp_path / "DCIM"
    img.mkdir()
    (img / "DSC00001.JPG").write_bytes(b"\xff\xd8\xff\xd9")
    res = CliRunner().invoke(main, ["log", "ingest", str(LOG), "--images", str(img), "-o", str(img)])
    assert res.exit_code == 2 and "did not write there (DSC00001.JPG)" in res.output, res.output
    assert sorted(p.name for p in img.iterdir()) == ["DSC00001.JPG"]
