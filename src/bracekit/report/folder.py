"""Output folders whole at every instant, marked as bracekit's, never deleting a file bracekit did not write.

Rules of an output folder OUT (``bracekit run --out OUT``, ``validate --out``, ``sweep --out``, :func:`write_run`):

* OUT is checked and locked by :func:`prepare_output` before any computation: a named folder (not '' or '.'),
  not a file, not a mount point, not holding the working folder, a name short enough for the file system (with
  the ``.OUT.tmp-…`` name beside it), writable, its parent writable, no other bracekit process writing to it
  (lock file ``.OUT.lock`` beside it).
* Leftovers of a killed run are recovered first, under the lock: a previous output moved aside
  (``.OUT.old-<pid>-<hex>``) is put back when OUT is missing, and the temporary folders of dead processes are
  emptied of what bracekit wrote (see :func:`bracekit.report.swap.discard`).
* The new output is written whole into a temporary sibling ``.OUT.tmp-<pid>-<hex>`` with its manifest,
  ``.bracekit-output.json``, naming each file bracekit wrote with its SHA-256. Files bracekit did not write
  (kept with ``overwrite``) and bracekit's work folders (``keep``, e.g. a sweep's ``.sweep``) are carried into it
  as hard links. Then OUT is swapped in two renames (OUT → ``.OUT.old-…``, temporary → OUT): a kill at any
  point leaves OUT missing for an instant at most, and the next run puts the previous output back.
* A file is bracekit's only when the manifest lists it *and* its SHA-256 matches: a manifest edited to list a
  user's file does not make bracekit delete or replace it. A file bracekit did not write is never deleted or
  replaced, even with ``overwrite`` (a name clash is refused).
* New folders follow the umask; a replaced OUT keeps its permissions.
"""

from __future__ import annotations

import errno
import json
import os
import shutil
import stat
import sys
import time
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from types import TracebackType

from bracekit._version import __version__
from bracekit.errors import OutputError
from bracekit.report.lock import lock_output, lock_path, unlock_output
from bracekit.report.swap import (
    MANIFEST,
    Contents,
    carry,
    discard,
    exchange,
    inspect,
    reason,
    recover,
    sha256,
    sibling,
    tree_ids,
)

__all__ = ["MANIFEST", "OutputPlan", "atomic_directory", "prepare_output"]

_SHOWN = 5  # names listed in an error message
#: Room a sibling name ``.OUT.tmp-<pid>-<hex>`` needs beyond OUT's own name, characters.
_SIBLING_ROOM = 32


@dataclass
class OutputPlan:
    """An output folder checked and locked by :func:`prepare_output`; close it (or use `with`) to unlock.

    Attributes:
        path: The folder the output goes to (absolute, a symbolic link to a folder resolved).
        shown: The folder as the caller named it (used in messages).
        overwrite: Whether bracekit's files may be replaced in a folder that also holds other files.
        files: The names the caller announced it will write (checked against the folder up front).
        command: What wrote the output, recorded in the manifest.
        keep: bracekit's work folders in OUT carried into each new output (e.g. ``.sweep``).
        committed: True once an output was put in place.
    """

    path: Path
    shown: str
    overwrite: bool = False
    files: tuple[str, ...] = ()
    command: str = ""
    keep: tuple[str, ...] = ()
    committed: bool = False
    _lock: int | None = field(default=None, repr=False)
    _created: tuple[Path, ...] = field(default=(), repr=False)

    @property
    def closed(self) -> bool:
        """True once the lock is released."""
        return self._lock is None

    def close(self) -> None:
        """Release the lock; folders made for the output are removed again if nothing was put in place."""
        if self._lock is not None:
            unlock_output(self._lock, lock_path(self.path))
            self._lock = None
        if not self.committed:
            for folder in reversed(self._created):
                try:
                    folder.rmdir()
                except OSError:
                    break
            self._created = ()

    def __enter__(self) -> OutputPlan:
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()


def prepare_output(
    out: str | os.PathLike[str],
    *,
    overwrite: bool = False,
    files: Iterable[str] = (),
    command: str = "",
    keep: Iterable[str] = (),
) -> OutputPlan:
    """Check and lock an output folder before any computation; see the module docstring for the rules.

    Args:
        out: The output folder; missing parent folders are made (and removed again if nothing is written).
        overwrite: Replace bracekit's files in a folder that also holds other files (those are kept).
        files: The names that will be written, so that a clash with a file bracekit did not write is found now.
        command: What writes the output, recorded in the manifest.
        keep: bracekit's work folders inside OUT, carried into the new output (never symbolic links).

    Returns:
        The locked plan; pass it to :func:`atomic_directory` or :func:`write_run`, then close it.

    Raises:
        OutputError: OUT is '' or '.', a file, a mount point, holds the working folder, has too long a name, is
            not writable, in use by another bracekit process, or holds files bracekit did not write (without
            `overwrite`, or with a name bracekit would write).
    """
    shown = os.fspath(out)
    path = _target(shown)
    created = _make_parents(path.parent, shown)
    plan = OutputPlan(path, shown, overwrite, tuple(files), command, tuple(keep), _created=created)
    try:
        plan._lock = lock_output(path, shown)
        recover(path)
        _check_place(path, shown)
        _check(inspect(path, shown, plan.keep), path, shown, overwrite, {*plan.files, MANIFEST})
    except BaseException:
        plan.close()
        raise
    return plan


@contextmanager
def atomic_directory(
    target: OutputPlan | str | os.PathLike[str],
    *,
    overwrite: bool = False,
    files: Iterable[str] = (),
    command: str = "",
) -> Iterator[Path]:
    """Yield an empty temporary folder; when the block ends without error it replaces OUT whole.

    Args:
        target: A plan of :func:`prepare_output` (kept open), or a folder (prepared and closed here).
        overwrite: As in :func:`prepare_output` (only with a folder).
        files: As in :func:`prepare_output` (only with a folder).
        command: As in :func:`prepare_output` (only with a folder).

    Yields:
        The temporary folder to write into (a sibling of OUT, on the same file system).

    Raises:
        OutputError: The folder is refused (see :func:`prepare_output`), changed meanwhile, or cannot be written;
            OUT is then left as it was and the temporary folder removed.
    """
    own = not isinstance(target, OutputPlan)
    plan = (
        target
        if isinstance(target, OutputPlan)
        else prepare_output(target, overwrite=overwrite, files=files, command=command)
    )
    try:
        if plan.closed or plan.committed:
            raise OutputError(f"the plan for {plan.shown} is used up; call prepare_output again")
        tmp = sibling(plan.path, "tmp", make=True)
        try:
            yield tmp
            names = sorted(n for n in os.listdir(tmp) if n != MANIFEST)
            odd = [n for n in names if not _is_file(tmp / n)]
            if odd:
                raise OutputError(f"an output holds files only, got {', '.join(odd)} (not a regular file)")
            _commit(plan, tmp, names)
            plan.committed = True
        except OSError as exc:
            raise OutputError(
                f"cannot write the output for {plan.shown}: {reason(exc)}; {plan.shown} is unchanged"
            ) from exc
        finally:
            if os.path.lexists(tmp):
                shutil.rmtree(tmp, ignore_errors=True)  # only what bracekit wrote: nothing is carried into tmp
    finally:
        if own:
            plan.close()


# --- checks --------------------------------------------------------------------------------------------
def _name_max(folder: Path) -> tuple[int, int]:
    """(longest file name, longest path) of the file system holding `folder` (or its nearest existing parent)."""
    while not folder.exists() and folder != folder.parent:
        folder = folder.parent
    try:
        return os.pathconf(folder, "PC_NAME_MAX"), os.pathconf(folder, "PC_PATH_MAX")
    except (OSError, ValueError, AttributeError):
        return 255, 4096


def _target(shown: str) -> Path:
    if shown.strip() == "" or Path(shown).name in ("", ".", ".."):
        raise OutputError("the output folder must be a named folder (e.g. bracekit-out), not '' or '.'")
    if "\0" in shown:
        raise OutputError("the output folder's name holds a NUL character; give a folder path")
    path = Path(os.path.abspath(shown))
    name_max, path_max = _name_max(path.parent)
    long = [p for p in path.parts if len(os.fsencode(p)) > name_max]
    if long or len(os.fsencode(path.name)) + _SIBLING_ROOM > name_max:
        size = len(os.fsencode(long[0] if long else path.name))
        raise OutputError(
            f"the output folder's name has a part of {size} bytes; give names of at most "
            f"{name_max - _SIBLING_ROOM} bytes (bracekit writes .NAME.tmp-… beside it)"
        )
    if len(os.fsencode(str(path))) + _SIBLING_ROOM + name_max > path_max:
        raise OutputError(f"the output folder's path is too long for the file system (at most {path_max} bytes)")
    try:
        if path.is_symlink():
            if not path.exists():
                raise OutputError(f"output path {shown} is a broken symbolic link; give a folder path")
            path = Path(os.path.realpath(path))
        if path.exists() and not path.is_dir():
            raise OutputError(f"output path {shown} exists and is not a folder; give a folder path")
    except OSError as exc:
        raise OutputError(f"cannot use {shown} as the output folder: {reason(exc)}") from exc
    return path


def _check_place(path: Path, shown: str) -> None:
    """OutputError if OUT cannot be replaced by a rename: a mount point, the working folder's, not writable."""
    if not path.is_dir():
        return
    if os.path.ismount(path):
        raise OutputError(
            f"{shown} is a mount point, which bracekit cannot replace whole; give a folder inside it as the output"
        )
    try:
        inside = Path(os.getcwd()).is_relative_to(path)
    except OSError:
        inside = False
    if inside:
        raise OutputError(f"the working folder is inside {shown}, which bracekit replaces whole; run from elsewhere")
    if not os.access(path, os.W_OK | os.X_OK):
        raise OutputError(f"{shown} is not writable; choose another output folder or change its permissions")


def _make_parents(parent: Path, shown: str) -> tuple[Path, ...]:
    """Make the missing folders above OUT; return them, outermost first."""
    missing: list[Path] = []
    folder = parent
    while not folder.exists():
        if folder.is_symlink():
            raise OutputError(f"cannot write {shown}: {folder} is a broken symbolic link; choose another output folder")
        missing.append(folder)
        folder = folder.parent
    if not folder.is_dir():
        raise OutputError(f"cannot write {shown}: {folder} is not a folder; choose another output folder")
    made: list[Path] = []
    try:
        for folder in reversed(missing):
            try:
                folder.mkdir()
            except FileExistsError:  # made meanwhile by another process: not ours to remove
                if not folder.is_dir():
                    raise
                continue
            made.append(folder)
    except OSError as exc:
        for done in reversed(made):
            done.rmdir()
        raise OutputError(f"cannot make {folder} for {shown}: {reason(exc)}; choose another output folder") from exc
    return tuple(made)


def _is_file(path: Path) -> bool:
    try:
        return stat.S_ISREG(os.lstat(path).st_mode)
    except OSError:
        return False


def _names(path: Path, names: list[str]) -> str:
    shown = [n + ("/" if (path / n).is_dir() and not (path / n).is_symlink() else "") for n in names[:_SHOWN]]
    more = f" and {len(names) - _SHOWN} more" if len(names) > _SHOWN else ""
    return ", ".join(shown) + more


def _check(contents: Contents, path: Path, shown: str, overwrite: bool, names: set[str]) -> None:
    """Raise OutputError unless the new output may go into the folder (see the module docstring)."""
    foreign = contents.foreign
    if not foreign:
        return
    if not overwrite:
        raise OutputError(
            f"{shown} holds files bracekit did not write: {_names(path, foreign)}; "
            "choose another output folder or allow overwriting (overwrite=True)"
        )
    clash = [n for n in foreign if n in names]
    if clash:
        raise OutputError(
            f"{shown} holds {_names(path, clash)}, which bracekit did not write and never replaces, not even with "
            "overwrite=True; move it away or choose another output folder"
        )


# --- putting the output in place -----------------------------------------------------------------------
def write_manifest(folder: Path, names: Iterable[str], command: str, kept: Iterable[str] = ()) -> None:
    """The manifest of `folder`: each file bracekit wrote with its SHA-256, and the entries carried over."""
    listed = sorted(names)
    data = {
        "written_by": "bracekit",
        "version": __version__,
        "command": command,
        "written": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "files": listed,
        "sha256": {n: sha256(folder / n) for n in listed},
        "kept": sorted(kept),
        "note": "bracekit replaces or removes only the files listed here, and only while their SHA-256 matches",
    }
    with open(folder / MANIFEST, "w", encoding="utf-8") as fh:
        fh.write(json.dumps(data, indent=2) + "\n")
        fh.flush()
        os.fsync(fh.fileno())


def _commit(plan: OutputPlan, tmp: Path, names: list[str]) -> None:
    """Put the complete output of `tmp` in place as OUT; OUT is unchanged if this raises."""
    path, shown = plan.path, plan.shown
    contents = inspect(path, shown, plan.keep)  # again: OUT may have changed while the output was computed
    if contents.exists:
        _check(contents, path, shown, plan.overwrite, {*names, MANIFEST})
        _check_place(path, shown)
    carried = [*contents.foreign, *contents.work]
    write_manifest(tmp, names, plan.command, carried)
    if not contents.exists:
        try:
            os.rename(tmp, path)
        except OSError as exc:
            raise OutputError(f"cannot make {shown}: {reason(exc)}; choose another output folder") from exc
        return
    new = sibling(path, "new")
    os.rename(tmp, new)  # from here a leftover is emptied by hashes and inodes only (see discard)
    try:
        try:
            for name in carried:
                carry(path / name, new / name)
            os.chmod(new, stat.S_IMODE(os.stat(path).st_mode))  # the user's permissions on OUT stay
        except OSError as exc:
            hint = " (hard links are not supported there)" if exc.errno in (errno.EPERM, errno.EXDEV) else ""
            raise OutputError(
                f"cannot keep the other files of {shown} in the new output: {reason(exc)}{hint}; nothing was changed"
            ) from exc
        aside = _swap(path, shown, new, contents, carried)
    except BaseException:
        if os.path.lexists(new):
            discard(new, path)
        raise
    left = discard(aside, path)
    if left:
        print(
            f"bracekit: warning: {aside} holds {', '.join(left[:_SHOWN])}, which bracekit did not write and could "
            "not find in the new output; it is kept there",
            file=sys.stderr,
        )


def _changed(aside: Path, contents: Contents, carried: list[str], new: Path) -> list[str]:
    """Entries of the previous OUT (now at `aside`) that appeared or changed since they were checked."""
    now = set(os.listdir(aside))
    late = sorted(now - set(contents.entries))
    return late + [n for n in carried if n not in now or tree_ids(aside / n) != tree_ids(new / n)]


def _swap(path: Path, shown: str, new: Path, contents: Contents, carried: list[str]) -> Path:
    """Replace OUT by `new` in one atomic exchange (or two renames); return where the previous OUT now is.

    With two renames a kill between them leaves OUT missing for an instant: the next run puts it back (recover).
    """
    try:
        swapped = exchange(new, path)
    except OSError as exc:
        raise OutputError(f"cannot replace {shown}: {reason(exc)}; its previous output is unchanged") from exc
    if swapped:
        changed = _changed(new, contents, carried, path)
        if changed:
            exchange(new, path)
            raise OutputError(
                f"{shown} changed while bracekit was writing ({_names(new, changed)}); "
                "its previous output is unchanged, run again"
            )
        return new
    old = sibling(path, "old")
    try:
        os.rename(path, old)
    except OSError as exc:
        raise OutputError(f"cannot replace {shown}: {reason(exc)}; its previous output is unchanged") from exc
    try:
        changed = _changed(old, contents, carried, new)
        if changed:
            raise OutputError(
                f"{shown} changed while bracekit was writing ({_names(old, changed)}); "
                "its previous output is unchanged, run again"
            )
        os.rename(new, path)
    except BaseException as exc:
        try:
            os.rename(old, path)
        except OSError:
            raise OutputError(f"cannot replace {shown}; its previous output is in {old}") from exc
        if isinstance(exc, OSError):
            raise OutputError(f"cannot replace {shown}: {reason(exc)}; its previous output is unchanged") from exc
        raise
    return old
