"""Output folders written whole or not at all, marked as bracekit's, never touching files bracekit did not write.

Rules of an output folder OUT (``bracekit run --out OUT``, ``bracekit validate --out OUT``, :func:`write_run`):

* OUT is checked and locked by :func:`prepare_output` before any computation: a named folder (not '' or '.'),
  not a file, its parent writable, no other bracekit process writing to it (lock file ``.OUT.lock`` beside it).
* The new files are written into a temporary sibling ``.OUT.tmp-<pid>-<hex>`` and only then put in place; on
  an error or an interrupt the temporary folder is removed and OUT is left as it was.
* Every folder bracekit writes holds a manifest, ``.bracekit-output.json``, naming the files it wrote.
* A missing OUT is created; a previous bracekit output (only files its manifest names) is replaced whole by a
  rename; an empty folder receives the files.
* A folder holding anything bracekit did not write is refused, unless ``overwrite``: then bracekit's earlier
  files there are replaced or removed and every other file is kept. A file bracekit did not write is never
  deleted or replaced, even with ``overwrite``.
* Leftover temporary folders of processes that no longer run are removed by the next run into OUT.
* New folders follow the umask.
"""

from __future__ import annotations

import json
import math
import os
import re
import secrets
import shutil
import stat
import sys
import time
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from types import ModuleType, TracebackType
from typing import TYPE_CHECKING, Any

import numpy as np

from bracekit._version import __version__
from bracekit.errors import MissingDependencyError, OutputError
from bracekit.report.table import table_csv, table_markdown
from bracekit.viewer.scene import scene_data

if TYPE_CHECKING:
    from bracekit.simulation.run import RunResult

#: Every file `write_run` may write (the first six without figures).
FILES = (
    "summary.json",
    "summary_all_models.json",
    "table.md",
    "table.csv",
    "trajectories.npz",
    "scene.json",
    "fig2_film_strip.png",
    "fig3_ellipsoids.png",
    "fig4_measures.png",
    "animation.gif",
    "fig_capacity.png",
)
#: The manifest bracekit writes into each output folder: the files it wrote, the command and the version.
MANIFEST = ".bracekit-output.json"
_MARK = "bracekit"
_SHOWN = 5  # names listed in an error message


def run_files(figures: bool = True) -> tuple[str, ...]:
    """The names of the files `write_run` writes, with or without the figures."""
    return FILES if figures else FILES[:6]


def _clean(value: Any) -> Any:
    """JSON-safe copy: numpy scalars → Python, non-finite floats refused (never silently written)."""
    if isinstance(value, dict):
        return {str(k): _clean(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_clean(v) for v in value]
    if isinstance(value, np.ndarray):
        return _clean(value.tolist())
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        raise ValueError(f"refusing to write a non-finite number ({value}) to JSON")
    return value


def to_json(data: Any) -> str:
    """Indented JSON of SI results; raises ValueError on NaN or inf."""
    return json.dumps(_clean(data), indent=2, allow_nan=False)


# --- the plan: a checked, locked output folder ---------------------------------------------------------
@dataclass
class OutputPlan:
    """An output folder checked and locked by :func:`prepare_output`; close it (or use `with`) to unlock.

    Attributes:
        path: The folder the output goes to (absolute, a symbolic link to a folder resolved).
        shown: The folder as the caller named it (used in messages).
        overwrite: Whether bracekit's files may be replaced in a folder that also holds other files.
        files: The names the caller announced it will write (checked against the folder up front).
        command: What wrote the output, recorded in the manifest.
        committed: True once an output was put in place.
    """

    path: Path
    shown: str
    overwrite: bool = False
    files: tuple[str, ...] = ()
    command: str = ""
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
            _unlock(self._lock, _lock_path(self.path))
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
    out: str | os.PathLike[str], *, overwrite: bool = False, files: Iterable[str] = (), command: str = ""
) -> OutputPlan:
    """Check and lock an output folder before any computation; see the module docstring for the rules.

    Args:
        out: The output folder; missing parent folders are made (and removed again if nothing is written).
        overwrite: Replace bracekit's files in a folder that also holds other files (those are kept).
        files: The names that will be written, so that a clash with a file bracekit did not write is found now.
        command: What writes the output, recorded in the manifest.

    Returns:
        The locked plan; pass it to :func:`atomic_directory` or :func:`write_run`, then close it.

    Raises:
        OutputError: OUT is '' or '.', a file, not writable, in use by another bracekit process, or holds
            files bracekit did not write (without `overwrite`, or with a name bracekit would write).
    """
    shown = os.fspath(out)
    path = _target(shown)
    created = _make_parents(path.parent, shown)
    plan = OutputPlan(path, shown, overwrite, tuple(files), command, _created=created)
    try:
        plan._lock = _lock(path, shown)
        _remove_leftovers(path)
        _check(_inspect(path, shown), path, shown, overwrite, {*plan.files, MANIFEST})
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
    """Yield an empty temporary folder; when the block ends without error its files are put in place in OUT.

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
        tmp = _sibling(plan.path, "tmp", make=True)
        try:
            try:
                yield tmp
                names = sorted(n for n in os.listdir(tmp) if n != MANIFEST)
                odd = [n for n in names if not _is_file(tmp / n)]
                if odd:
                    raise OutputError(f"an output holds files only, got {', '.join(odd)} (not a regular file)")
                _write_manifest(tmp / MANIFEST, names, plan.command)
            except OSError as exc:
                raise OutputError(f"cannot write the output for {plan.shown}: {_reason(exc)}") from exc
            _commit(plan, tmp, names)
            plan.committed = True
        finally:
            if os.path.lexists(tmp):
                shutil.rmtree(tmp, ignore_errors=True)
    finally:
        if own:
            plan.close()


# --- checks --------------------------------------------------------------------------------------------
def _reason(exc: OSError) -> str:
    where = f" ({Path(exc.filename).name})" if exc.filename else ""
    return f"{exc.strerror or exc}{where}"


def _target(shown: str) -> Path:
    if shown.strip() == "" or Path(shown).name in ("", ".", ".."):
        raise OutputError("the output folder must be a named folder (e.g. bracekit-out), not '' or '.'")
    path = Path(os.path.abspath(shown))
    if path.is_symlink():
        if not path.exists():
            raise OutputError(f"output path {shown} is a broken symbolic link; give a folder path")
        path = Path(os.path.realpath(path))
    if path.exists() and not path.is_dir():
        raise OutputError(f"output path {shown} exists and is not a folder; give a folder path")
    return path


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
        raise OutputError(f"cannot make {folder} for {shown}: {_reason(exc)}; choose another output folder") from exc
    return tuple(made)


@dataclass(frozen=True)
class _Contents:
    exists: bool
    entries: tuple[str, ...] = ()
    ours: frozenset[str] = frozenset()  # regular files the manifest names, and the manifest itself
    manifest: bytes | None = None

    @property
    def foreign(self) -> list[str]:
        return [n for n in self.entries if n not in self.ours]


def _is_file(path: Path) -> bool:
    try:
        return stat.S_ISREG(os.lstat(path).st_mode)
    except OSError:
        return False


def _manifest_files(raw: bytes) -> set[str] | None:
    """The file names a manifest lists, or None if it is not a bracekit manifest."""
    try:
        data = json.loads(raw)
    except (ValueError, UnicodeDecodeError):
        return None
    if not isinstance(data, dict) or data.get("written_by") != _MARK or not isinstance(data.get("files"), list):
        return None
    names = data["files"]
    if not all(isinstance(n, str) and n == Path(n).name and n not in ("", ".", "..", MANIFEST) for n in names):
        return None
    return set(names)


def _inspect(path: Path, shown: str) -> _Contents:
    try:
        entries = tuple(sorted(os.listdir(path)))
    except FileNotFoundError:
        return _Contents(exists=False)
    except OSError as exc:
        raise OutputError(f"cannot read {shown}: {_reason(exc)}; choose another output folder") from exc
    raw = None
    if MANIFEST in entries and _is_file(path / MANIFEST):
        try:
            raw = (path / MANIFEST).read_bytes()
        except OSError:
            raw = None
    listed = None if raw is None else _manifest_files(raw)
    if listed is None:
        return _Contents(True, entries)
    ours = {n for n in entries if n in listed and _is_file(path / n)} | {MANIFEST}
    return _Contents(True, entries, frozenset(ours), raw)


def _names(path: Path, names: list[str]) -> str:
    shown = [n + ("/" if (path / n).is_dir() and not (path / n).is_symlink() else "") for n in names[:_SHOWN]]
    more = f" and {len(names) - _SHOWN} more" if len(names) > _SHOWN else ""
    return ", ".join(shown) + more


def _check(contents: _Contents, path: Path, shown: str, overwrite: bool, names: set[str]) -> None:
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


# --- the lock and leftovers ----------------------------------------------------------------------------
def _lock_path(path: Path) -> Path:
    return path.parent / f".{path.name}.lock"


def _busy(shown: str, pid: str, lock: Path) -> OutputError:
    who = f" (pid {pid})" if pid.isdigit() else ""
    return OutputError(
        f"another bracekit process{who} is writing to {shown} (lock {lock.name}); "
        "wait for it or choose another output folder"
    )


def _lock(path: Path, shown: str) -> int:
    """Take the lock of OUT: a file `.OUT.lock` beside it holding the pid, flock-ed while the plan is open."""
    lock = _lock_path(path)
    if sys.platform == "win32":  # no flock: a lock file made with O_EXCL, removed on close
        try:
            fd = os.open(lock, os.O_RDWR | os.O_CREAT | os.O_EXCL, 0o666)
        except FileExistsError:
            raise _busy(shown, lock.read_text(encoding="ascii", errors="replace").strip(), lock) from None
        except OSError as exc:
            raise OutputError(f"cannot write beside {shown}: {_reason(exc)}; choose another output folder") from exc
        os.write(fd, f"{os.getpid()}\n".encode("ascii"))
        return fd
    import fcntl

    while True:
        try:
            fd = os.open(lock, os.O_RDWR | os.O_CREAT, 0o666)
        except OSError as exc:
            raise OutputError(f"cannot write beside {shown}: {_reason(exc)}; choose another output folder") from exc
        try:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                raise _busy(shown, os.pread(fd, 32, 0).decode("ascii", "replace").strip(), lock) from None
            try:
                same = os.path.samestat(os.fstat(fd), os.stat(lock))
            except FileNotFoundError:
                same = False
            if same:
                held = os.pread(fd, 64, 0).decode("ascii", "replace").strip()
                if held and not held.isdigit():
                    raise OutputError(
                        f"{lock} is not bracekit's lock file; move it away or choose another output folder"
                    )
                os.ftruncate(fd, 0)
                os.pwrite(fd, f"{os.getpid()}\n".encode("ascii"), 0)
                return fd
        except OSError as exc:
            os.close(fd)
            raise OutputError(f"cannot lock {shown}: {_reason(exc)}; choose another output folder") from exc
        except BaseException:
            os.close(fd)
            raise
        os.close(fd)  # its holder removed it between our open and flock: take the new one


def _unlock(fd: int, lock: Path) -> None:
    if sys.platform == "win32":
        os.close(fd)
        lock.unlink(missing_ok=True)
        return
    try:  # removed while still held: a process that opened the old file sees it is gone and opens the new one
        lock.unlink(missing_ok=True)
    finally:
        os.close(fd)


def _alive(pid: int) -> bool:
    """Whether process `pid` runs (True when unsure: a folder of a live process is never removed)."""
    if pid == os.getpid() or sys.platform == "win32":  # os.kill(pid, 0) would end the process on Windows
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:
        return True
    return True


def _sibling(path: Path, kind: str, make: bool = False) -> Path:
    """A new name `.OUT.<kind>-<pid>-<hex>` beside OUT; with `make`, the folder (mode from the umask)."""
    while True:
        candidate = path.parent / f".{path.name}.{kind}-{os.getpid()}-{secrets.token_hex(4)}"
        if not make:
            if not os.path.lexists(candidate):
                return candidate
            continue
        try:
            candidate.mkdir(0o777)  # 0o777 & ~umask, unlike mkdtemp's 0o700
        except FileExistsError:
            continue
        except OSError as exc:
            raise OutputError(
                f"cannot write beside {path.name} (in {path.parent}): {_reason(exc)}; choose another output folder"
            ) from exc
        return candidate


def _remove_leftovers(path: Path) -> None:
    """Remove `.OUT.tmp-*` and `.OUT.old-*` folders of processes that no longer run (we hold the lock).

    A swap cut short leaves OUT missing and its previous output in `.OUT.old-*`: that output is put back.
    """
    pattern = re.compile(re.escape(f".{path.name}.") + r"(tmp|old)-(\d+)-[0-9a-f]{8}")
    try:
        entries = list(os.scandir(path.parent))
    except OSError:
        return
    for entry in sorted(entries, key=lambda e: e.name):
        match = pattern.fullmatch(entry.name)
        if match is None or not entry.is_dir(follow_symlinks=False) or _alive(int(match[2])):
            continue
        if match[1] == "old" and not os.path.lexists(path) and _is_file(Path(entry.path) / MANIFEST):
            try:
                os.rename(entry.path, path)
                continue
            except OSError:
                pass
        shutil.rmtree(entry.path, ignore_errors=True)


# --- putting the output in place -----------------------------------------------------------------------
def _write_manifest(path: Path, names: Iterable[str], command: str) -> None:
    data = {
        "written_by": _MARK,
        "version": __version__,
        "command": command,
        "written": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "files": sorted(names),
        "note": "bracekit replaces or removes only the files listed here",
    }
    path.write_text(json.dumps(data, indent=2) + "\n", encoding="utf-8")


def _commit(plan: OutputPlan, tmp: Path, names: list[str]) -> None:
    """Put the complete output of `tmp` in place in OUT; OUT is unchanged if this raises."""
    path, shown = plan.path, plan.shown
    contents = _inspect(path, shown)  # again: OUT may have changed while the output was computed
    if not contents.exists:
        try:
            os.rename(tmp, path)
        except OSError as exc:
            raise OutputError(f"cannot make {shown}: {_reason(exc)}; choose another output folder") from exc
        return
    _check(contents, path, shown, plan.overwrite, {*names, MANIFEST})
    whole = contents.entries and not contents.foreign and not os.path.ismount(path) and not _holds_cwd(path)
    if not (whole and _swap(path, shown, tmp)):
        _merge(path, shown, tmp, names, contents)


def _holds_cwd(path: Path) -> bool:
    """Whether the working folder is OUT or inside it (then OUT is not moved away under the user's feet)."""
    try:
        return Path(os.getcwd()).is_relative_to(path)
    except OSError:
        return False


def _swap(path: Path, shown: str, tmp: Path) -> bool:
    """Replace a previous bracekit output whole: move it aside, move the new one in, remove the old one.

    Returns False, with nothing changed, if OUT cannot be moved aside (then the files are moved one by one).
    """
    old = _sibling(path, "old")
    try:
        os.chmod(tmp, stat.S_IMODE(os.stat(path).st_mode))  # the user's permissions on OUT stay
        os.rename(path, old)
    except OSError:
        return False
    try:
        late = _inspect(old, shown).foreign
        if late:
            raise OutputError(
                f"{shown} changed while bracekit was writing ({_names(old, late)} appeared); "
                "its previous output is unchanged, run again"
            )
        os.rename(tmp, path)
    except BaseException as exc:
        try:
            os.rename(old, path)
        except OSError:
            raise OutputError(f"cannot replace {shown}; its previous output is in {old}") from exc
        if isinstance(exc, OSError):
            raise OutputError(f"cannot replace {shown}: {_reason(exc)}; its previous output is unchanged") from exc
        raise
    shutil.rmtree(old, ignore_errors=True)  # only bracekit's files: checked after the move aside
    return True


def _merge(path: Path, shown: str, tmp: Path, names: list[str], contents: _Contents) -> None:
    """Move the new files into a folder that also holds other files (or none); keep every file not bracekit's.

    Bracekit's previous files go to a backup folder first and come back if anything fails. The manifest in OUT
    names every bracekit file there at each step, so even a killed process leaves a folder the next run reads.
    """
    previous = sorted(contents.ours - {MANIFEST})
    backup = _sibling(path, "old", make=True)
    union = tmp / f"{MANIFEST}.union"
    moved_out: list[str] = []
    moved_in: list[str] = []
    try:
        _write_manifest(union, {*previous, *names}, "")
        os.replace(union, path / MANIFEST)
        for name in previous:
            os.rename(path / name, backup / name)
            moved_out.append(name)
        for name in names:
            if os.path.lexists(path / name):
                raise OutputError(f"{name} appeared in {shown} while bracekit was writing; nothing was changed")
            os.rename(tmp / name, path / name)
            moved_in.append(name)
        os.replace(tmp / MANIFEST, path / MANIFEST)
    except BaseException as exc:
        lost = _roll_back(path, tmp, backup, moved_in, moved_out, contents.manifest)
        if lost:  # the backup holds bracekit's previous files that could not be put back: never removed
            if not isinstance(exc, Exception):
                raise
            raise OutputError(
                f"cannot write into {shown}; bracekit's previous {', '.join(lost)} could not be put back and are in "
                f"{backup}"
            ) from exc
        shutil.rmtree(backup, ignore_errors=True)
        if isinstance(exc, OSError):
            raise OutputError(f"cannot write into {shown}: {_reason(exc)}; nothing was changed") from exc
        raise
    shutil.rmtree(backup, ignore_errors=True)  # bracekit's previous files only


def _roll_back(
    path: Path, tmp: Path, backup: Path, moved_in: list[str], moved_out: list[str], manifest: bytes | None
) -> list[str]:
    """Undo a merge; return bracekit's previous files that could not be put back."""
    for name in reversed(moved_in):
        try:
            os.rename(path / name, tmp / name)
        except OSError:
            pass
    lost: list[str] = []
    for name in reversed(moved_out):
        try:
            os.rename(backup / name, path / name)
        except OSError:
            lost.append(name)
    try:
        if manifest is None:
            (path / MANIFEST).unlink(missing_ok=True)
        else:
            restore = tmp / f"{MANIFEST}.previous"
            restore.write_bytes(manifest)
            os.replace(restore, path / MANIFEST)
    except OSError:
        pass
    return lost


# --- a run's files -------------------------------------------------------------------------------------
def save_trajectories(result: RunResult, path: Path) -> None:
    """All runs as one NPZ: keys '<model>/<strategy>/t', '.../q' and '.../<measure>' (SI units)."""
    arrays: dict[str, Any] = {"joint_names": np.array(result.scenario.robot.joint_names)}
    for model, runs in result.trajectories.items():
        for name, tr in runs.items():
            arrays[f"{model}/{name}/t"] = tr.t
            arrays[f"{model}/{name}/q"] = tr.q
            for key, values in tr.measures.items():
                arrays[f"{model}/{name}/{key}"] = values
    with open(path, "wb") as fh:
        np.savez_compressed(fh, **arrays)


def write_run(
    result: RunResult,
    out: OutputPlan | str | os.PathLike[str],
    *,
    figures: bool = True,
    overwrite: bool = False,
    progress: Callable[[str], None] | None = None,
) -> list[Path]:
    """Write summary.json, table.md/.csv, trajectories.npz, scene.json and (optionally) Figures 2–4 and the GIF, whole.

    Args:
        result: The run to report.
        out: The output folder, or a plan of :func:`prepare_output` (the command line checks OUT before running).
        figures: Also write Figures 2–4 and the animation (needs matplotlib).
        overwrite: Replace bracekit's files in a folder that also holds other files; those are kept.
        progress: Called with each file name before it is written.

    Returns:
        The paths of the files written (the manifest `.bracekit-output.json` aside).

    Raises:
        OutputError: The folder is refused or cannot be written (see :func:`prepare_output`); nothing is changed.
    """
    steps: list[tuple[str, Callable[[Path], object]]] = [
        ("summary.json", lambda p: p.write_text(to_json(result.summary) + "\n", encoding="utf-8")),
        ("summary_all_models.json", lambda p: p.write_text(to_json(result.summaries) + "\n", encoding="utf-8")),
        ("table.md", lambda p: p.write_text(table_markdown(result.summaries, result.scenario.name), encoding="utf-8")),
        ("table.csv", lambda p: p.write_text(table_csv(result.summaries, result.scenario.name), encoding="utf-8")),
        ("trajectories.npz", lambda p: save_trajectories(result, p)),
        ("scene.json", lambda p: p.write_text(to_json(scene_data(result)) + "\n", encoding="utf-8")),
    ]
    names = [name for name, _ in steps]
    drawing: ModuleType | None = None
    if figures:
        try:
            from bracekit.report import figures as fig  # matplotlib only when figures are asked for
        except ImportError as exc:
            raise MissingDependencyError(
                f"figures need matplotlib, which cannot be imported ({exc}): pip install 'bracekit[viz]', "
                "or write without figures"
            ) from exc
        names += fig.figure_files(result)
        drawing = fig
    with atomic_directory(out, overwrite=overwrite, files=names, command="bracekit.report.write_run") as tmp:
        for name, write in steps:
            if progress is not None:
                progress(name)
            write(tmp / name)
        if drawing is not None:
            drawing.write_figures(result, tmp, progress)
    shown = out.shown if isinstance(out, OutputPlan) else os.fspath(out)
    return [Path(shown) / name for name in names]
