"""What an output folder holds and whose it is; carrying entries into a new output; recovering after a kill.

A file in OUT is bracekit's when the manifest lists it and its SHA-256 matches the one recorded there. Entries
that are not bracekit's are carried into a new output as hard links (never copied, moved or deleted), and a
leftover folder of a killed run is emptied only of what is provably bracekit's or present, as the very same
file (same inode), in OUT: so no user file is ever lost, whenever a run is killed.
"""

from __future__ import annotations

import ctypes
import errno
import hashlib
import os
import re
import secrets
import shutil
import stat
import sys
from dataclasses import dataclass
from pathlib import Path

from bracekit._io import loads_json
from bracekit.errors import InputError, OutputError
from bracekit.report.lock import alive, reason

#: The manifest bracekit writes into each output folder: the files it wrote with their SHA-256, the command, the
#: version and the entries carried over from the previous folder.
MANIFEST = ".bracekit-output.json"
#: Largest manifest read, bytes.
MAX_MANIFEST_BYTES = 1024 * 1024

__all__ = [
    "MANIFEST",
    "Contents",
    "carry",
    "discard",
    "exchange",
    "inspect",
    "reason",
    "recover",
    "sha256",
    "sibling",
    "tree_ids",
]


@dataclass(frozen=True)
class Contents:
    """The entries of OUT: `owned` bracekit's (hash checked, the manifest included), `work` its work folders."""

    exists: bool
    entries: tuple[str, ...] = ()
    owned: frozenset[str] = frozenset()
    work: tuple[str, ...] = ()

    @property
    def foreign(self) -> list[str]:
        """Entries bracekit did not write (kept, never deleted)."""
        return [n for n in self.entries if n not in self.owned and n not in self.work]


def sha256(path: Path) -> str:
    """The SHA-256 of a file, hex."""
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            digest.update(chunk)
    return digest.hexdigest()


def _regular(path: Path) -> bool:
    try:
        return stat.S_ISREG(os.lstat(path).st_mode)
    except OSError:
        return False


def _manifest(folder: Path) -> dict[str, object] | None:
    """The manifest of `folder` if it is a readable bracekit manifest, else None."""
    path = folder / MANIFEST
    if not _regular(path):
        return None
    try:
        with open(path, "rb") as fh:
            raw = fh.read(MAX_MANIFEST_BYTES + 1)
        data = loads_json(raw, "the output manifest") if len(raw) <= MAX_MANIFEST_BYTES else None
    except (OSError, InputError):
        return None
    if not isinstance(data, dict) or data.get("written_by") != "bracekit" or not isinstance(data.get("files"), list):
        return None
    return data


def _hashes(data: dict[str, object]) -> dict[str, str]:
    """File name → SHA-256 of the files a manifest lists with a hash (plain names only)."""
    files, sums = data.get("files"), data.get("sha256")
    if not isinstance(files, list) or not isinstance(sums, dict):
        return {}
    out: dict[str, str] = {}
    for n in files:
        if isinstance(n, str) and n == Path(n).name and n not in ("", ".", "..", MANIFEST):
            value = sums.get(n)
            if isinstance(value, str):
                out[n] = value
    return out


def owned_files(folder: Path, entries: tuple[str, ...]) -> frozenset[str]:
    """The entries of `folder` that are bracekit's: the manifest and each file it lists whose SHA-256 matches."""
    data = _manifest(folder)
    if data is None:
        return frozenset()
    hashes = _hashes(data)
    ours = {MANIFEST}
    for n in entries:
        if n in hashes and _regular(folder / n):
            try:
                if sha256(folder / n) == hashes[n]:
                    ours.add(n)
            except OSError:
                continue
    return frozenset(ours)


def inspect(path: Path, shown: str, keep: tuple[str, ...] = ()) -> Contents:
    """The entries of OUT and whose they are; OutputError if OUT cannot be read or a work folder is a link."""
    try:
        entries = tuple(sorted(os.listdir(path)))
    except FileNotFoundError:
        return Contents(exists=False)
    except OSError as exc:
        raise OutputError(f"cannot read {shown}: {reason(exc)}; choose another output folder") from exc
    work = tuple(n for n in keep if n in entries)
    for n in work:
        mode = os.lstat(path / n).st_mode
        if not stat.S_ISDIR(mode):
            what = "a symbolic link" if stat.S_ISLNK(mode) else "not a folder"
            raise OutputError(
                f"{shown}/{n} is {what}; bracekit writes only inside the output folder: remove it or choose another "
                "output folder"
            )
    return Contents(True, entries, owned_files(path, entries), work)


def sibling(path: Path, kind: str, make: bool = False) -> Path:
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
                f"cannot write beside {path.name} (in {path.parent}): {reason(exc)}; choose another output folder"
            ) from exc
        return candidate


def carry(src: Path, dst: Path) -> None:
    """Hard-link the entry `src` (a file, a link, or a folder tree: folders made anew) to `dst`; nothing is copied."""
    if not stat.S_ISDIR(os.lstat(src).st_mode):
        os.link(src, dst, follow_symlinks=False)
        return
    modes: list[tuple[Path, int]] = []
    for root, dirs, files in os.walk(src, followlinks=False):
        here = dst / os.path.relpath(root, src)
        here.mkdir(0o700)
        modes.append((here, stat.S_IMODE(os.lstat(root).st_mode)))
        for name in files + [d for d in dirs if os.path.islink(os.path.join(root, d))]:
            os.link(os.path.join(root, name), here / name, follow_symlinks=False)
    for folder, mode in reversed(modes):  # last: a read-only folder is filled first
        os.chmod(folder, mode)


def tree_ids(path: Path) -> dict[str, tuple[int, int] | None]:
    """Relative path → (device, inode) of each non-folder entry under `path` (None for folders)."""
    try:
        st = os.lstat(path)
    except OSError:
        return {}
    if not stat.S_ISDIR(st.st_mode):
        return {".": (st.st_dev, st.st_ino)}
    out: dict[str, tuple[int, int] | None] = {}
    for root, dirs, files in os.walk(path, followlinks=False):
        out[os.path.relpath(root, path)] = None
        for name in files + [d for d in dirs if os.path.islink(os.path.join(root, d))]:
            s = os.lstat(os.path.join(root, name))
            out[os.path.relpath(os.path.join(root, name), path)] = (s.st_dev, s.st_ino)
    return out


def _same(a: os.stat_result, b: Path) -> bool:
    try:
        s = os.lstat(b)
    except OSError:
        return False
    return (s.st_dev, s.st_ino) == (a.st_dev, a.st_ino)


def discard(folder: Path, against: Path) -> list[str]:
    """Empty a folder bracekit made beside OUT of what it may remove; return what is left there (kept).

    An entry is removed when it is bracekit's (its top-level name listed in the folder's own manifest with a
    matching SHA-256, or the manifest itself) or when the very same file (same inode) is at the same place in
    `against` (OUT). Everything else — a user's file that is nowhere else — is left in place.
    """
    owned = owned_files(folder, tuple(os.listdir(folder))) if folder.is_dir() else frozenset()
    left: list[str] = []
    for root, dirs, files in os.walk(folder, topdown=False, followlinks=False):
        for name in files + [d for d in dirs if os.path.islink(os.path.join(root, d))]:
            p = Path(root, name)
            rel = os.path.relpath(p, folder)
            try:
                if rel.split(os.sep, 1)[0] in owned or _same(os.lstat(p), against / rel):
                    os.unlink(p)
                else:
                    left.append(rel)
            except OSError:
                left.append(rel)
        for name in dirs:
            p = Path(root, name)
            if not p.is_symlink():
                try:
                    p.rmdir()
                except OSError:
                    pass
    try:
        folder.rmdir()
    except OSError:
        pass
    return sorted(left)


def exchange(a: Path, b: Path) -> bool:
    """Swap the folders `a` and `b` in one atomic step (Linux renameat2 RENAME_EXCHANGE); False if unsupported."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        call = ctypes.CDLL(None, use_errno=True).renameat2
    except (AttributeError, OSError):
        return False
    at_cwd, rename_exchange = -100, 2
    if call(at_cwd, os.fsencode(a), at_cwd, os.fsencode(b), rename_exchange) == 0:
        return True
    code = ctypes.get_errno()
    if code in (errno.ENOSYS, errno.EINVAL, errno.EOPNOTSUPP):
        return False
    raise OSError(code, os.strerror(code), str(b))


def recover(path: Path) -> None:
    """After a killed run (we hold the lock): put a previous output moved aside back, empty dead leftovers.

    Of processes that no longer run: ``.OUT.old-…`` is the previous OUT (renamed back when OUT is missing, else
    emptied of what the new OUT holds); ``.OUT.new-…`` a new output being swapped in, or the previous one just
    swapped out (emptied of bracekit's files and of what OUT holds); ``.OUT.tmp-…`` a new output being written,
    holding only what bracekit wrote (removed).
    """
    pattern = re.compile(re.escape(f".{path.name}.") + r"(old|new|tmp)-(\d+)-[0-9a-f]{8}")
    try:
        entries = list(os.scandir(path.parent))
    except OSError:
        return
    order = {"old": 0, "new": 1, "tmp": 2}
    found = []
    for entry in entries:
        match = pattern.fullmatch(entry.name)
        if match is not None and entry.is_dir(follow_symlinks=False) and not alive(int(match[2])):
            found.append((order[match[1]], entry.name, Path(entry.path)))
    for kind, _, leftover in sorted(found):
        if kind == 0 and not os.path.lexists(path):
            try:
                os.rename(leftover, path)
                continue
            except OSError:
                pass
        if kind == 2:
            shutil.rmtree(leftover, ignore_errors=True)
        else:
            discard(leftover, path)
