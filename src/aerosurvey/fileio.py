"""Atomic file output: a failed run leaves nothing half-written behind."""

from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path

from aerosurvey.errors import InputError


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def atomic_write_bytes(path: str | os.PathLike[str], data: bytes) -> None:
    """Write `data` to `path` through a temporary file in the same folder and a rename."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        os.fchmod(fd, 0o666 & ~_umask())  # mkstemp makes 0600; give the file the usual mode
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise


@contextlib.contextmanager
def staged_file(path: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a free temporary path next to `path` for a writer that makes its own file (GDAL); on
    success it is renamed to `path`, on an error removed."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.stem}.", suffix=path.suffix, dir=path.parent)
    os.close(fd)
    os.unlink(tmp)
    try:
        yield Path(tmp)
        os.replace(tmp, path)
    finally:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)


def atomic_write_text(path: str | os.PathLike[str], text: str) -> None:
    """Text variant of :func:`atomic_write_bytes` (UTF-8, '\\n' line ends on every OS)."""
    atomic_write_bytes(path, text.encode("utf-8"))


#: the list of files a staged run wrote, kept in the output folder: what the next run may replace
LISTING = ".aerosurvey-output"
_LISTING_HEAD = "# files aerosurvey wrote here; the next run replaces this folder whole only if it holds no others\n"


def _files(folder: Path) -> set[str]:
    """Every file (and symbolic link) under `folder`, as '/'-separated relative paths."""
    out: set[str] = set()
    for root, dirs, names in os.walk(folder):
        rel = Path(root).relative_to(folder)
        out.update((rel / n).as_posix() for n in names)
        out.update((rel / d).as_posix() for d in dirs if os.path.islink(os.path.join(root, d)))
    return out


def _listed(folder: Path) -> set[str] | None:
    try:
        text = (folder / LISTING).read_text("utf-8")
    except (FileNotFoundError, NotADirectoryError):
        return None
    return {line for line in text.splitlines() if line and not line.startswith("#")}


def _foreign(outdir: Path, target: Path, new: set[str] | None) -> None:
    """Refuse to replace a folder that holds files no aerosurvey run wrote there.

    Such files are the ones missing from the folder's LISTING; a folder without a listing
    (older versions wrote none) may be replaced only when the new outputs replace every
    file in it (`new`; None before they are known: then only an empty folder passes).
    """
    have = _files(target) - {LISTING}
    listed = _listed(target)
    others = sorted(have - listed) if listed is not None else sorted(have - (new or set()))
    if others:
        shown = ", ".join(others[:3]) + (f" and {len(others) - 3} more" if len(others) > 3 else "")
        raise InputError(f"output folder {str(outdir)!r} holds {len(others)} file(s) aerosurvey did not write there "
                         f"({shown}): the folder is replaced whole, so give a new or empty folder, or move those out")


def _output_place(outdir: Path) -> Path:
    """The folder's absolute path once its parent exists; a one-line InputError when it cannot be one."""
    target = Path(os.path.abspath(outdir))
    if target.exists() or target.is_symlink():
        target = target.resolve()
        if not target.is_dir():
            raise InputError(f"output folder {str(outdir)!r} is a file, not a folder")
    cwd = Path.cwd().resolve()
    if target == cwd or target in cwd.parents:
        raise InputError(f"output folder {str(outdir)!r} holds the current folder: it is replaced whole, give another one")
    ancestor = target.parent
    while not ancestor.exists() and ancestor != ancestor.parent:
        ancestor = ancestor.parent
    if not ancestor.is_dir():
        raise InputError(f"output folder {str(outdir)!r}: {str(ancestor)!r} is a file, not a folder")
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"output folder {str(outdir)!r}: cannot make its parent folder ({exc.strerror or exc})") from None
    return target


def _carry_over(outdir: Path, target: Path, stage: Path, written: set[str]) -> set[str]:
    """Hard-link (or, where the file system has no hard links, copy) into `stage` every file of
    `target` that the run did not write; returns their names."""
    kept = _files(target) - {LISTING} - written
    for name in sorted(kept):
        src, dst = target / name, stage / name
        try:
            dst.parent.mkdir(parents=True, exist_ok=True)
            try:
                os.link(src, dst, follow_symlinks=False)
            except OSError:
                shutil.copy2(src, dst, follow_symlinks=False)
        except OSError as exc:
            raise InputError(f"output folder {str(outdir)!r}: cannot keep its file {name} ({exc.strerror or exc}); "
                             "it is left as it was") from None
    return kept


@contextlib.contextmanager
def staged_directory(outdir: str | os.PathLike[str], merge: bool = False) -> Iterator[Path]:
    """Yield an empty staging folder; on success it replaces `outdir` whole.

    Every output of a command is written into the staging folder (a sibling of `outdir`),
    so an error anywhere leaves `outdir` as it was. On success the old folder is renamed
    to a backup name, the staged one to `outdir`, and only then is the backup deleted; if
    the second rename fails, the backup is renamed back. `outdir` never mixes files of two
    runs: outputs of an earlier run that this one does not write (a sortie fewer, no
    images this time) are gone with the old folder.

    Because the folder is replaced whole, a folder holding files that no aerosurvey run
    wrote there (the --images folder, the flight log, a spec, copies written into it while
    the command ran) is refused with an InputError before anything is written and again
    before the swap: nothing of the user's is ever deleted. What a run wrote is listed in
    the folder's LISTING file. A target that is a file, a parent that is a file, or a
    parent that cannot be written is an InputError naming the folder and the reason.

    merge=True is for a command that adds its files to a folder another command wrote (`gcp`
    writes its control point files into the plan folder): the files of `outdir` that the run
    does not write are hard-linked into the staged folder (copied where the file system has
    no hard links) before the same swap, so they are kept and the swap is still all or
    nothing. Nothing is refused then, and what the folder's listing named stays listed.
    """
    outdir = Path(outdir)
    target = _output_place(outdir)
    if not merge and target.exists() and _listed(target) is not None:
        _foreign(outdir, target, None)  # early, before any work; a folder without a listing is judged at the swap
    try:
        stage = Path(tempfile.mkdtemp(prefix=f".{target.name}.", suffix=".staging", dir=target.parent))
    except OSError as exc:
        raise InputError(f"output folder {str(outdir)!r}: cannot write in {str(target.parent)!r} "
                         f"({exc.strerror or exc})") from None
    try:
        yield stage
        written = _files(stage) - {LISTING}
        listing = set(written)
        if target.exists() and merge:
            kept = _carry_over(outdir, target, stage, written)
            listing |= kept & (_listed(target) or set())
        elif target.exists():
            _foreign(outdir, target, written)
        with open(stage / LISTING, "w", encoding="utf-8", newline="\n") as fh:
            fh.write(_LISTING_HEAD + "".join(f"{name}\n" for name in sorted(listing)))
        _swap(outdir, stage, target)
    finally:
        shutil.rmtree(stage, ignore_errors=True)


def _swap(outdir: Path, stage: Path, target: Path) -> None:
    """Rename `stage` to `target`; an existing `target` is kept under a backup name until then."""
    os.chmod(stage, 0o777 & ~_umask())  # mkdtemp makes 0700; give the folder the usual mode
    if not target.exists():
        try:
            os.replace(stage, target)
        except OSError as exc:
            raise InputError(f"output folder {str(outdir)!r} could not be written ({exc.strerror or exc})") from None
        return
    backup: Path | None = None
    try:
        backup = Path(tempfile.mkdtemp(prefix=f".{target.name}.", suffix=".previous", dir=target.parent))
        os.replace(target, backup)  # onto the empty placeholder mkdtemp made: a unique name
    except OSError as exc:
        if backup is not None:
            with contextlib.suppress(OSError):
                os.rmdir(backup)
        raise InputError(f"output folder {str(outdir)!r} could not be replaced ({exc.strerror or exc}); "
                         "it is left as it was") from None
    try:
        os.replace(stage, target)
    except OSError as exc:
        try:
            os.replace(backup, target)
        except OSError:
            raise InputError(f"output folder {str(outdir)!r} could not be replaced ({exc.strerror or exc}), nor put "
                             f"back: its previous contents are in {str(backup)!r}") from None
        raise InputError(f"output folder {str(outdir)!r} could not be replaced ({exc.strerror or exc}); "
                         "it is left as it was") from None
    shutil.rmtree(backup, ignore_errors=True)
