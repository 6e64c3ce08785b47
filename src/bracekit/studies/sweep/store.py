"""Resumable results of a sweep: one JSON file per finished candidate in a work folder, and the final tables.

The work folder is ``OUT/.sweep``: ``spec.json`` (the spec's fingerprint) and ``rows/<candidate>.json``, each
written whole (a temporary file renamed into place) as soon as the candidate finishes. A new run with the same
spec reads them and skips those candidates; a folder holding another spec's rows is refused. The final tables
(``results.parquet``, ``results.csv``) are written with the other outputs at the end (:mod:`.report`).
"""

from __future__ import annotations

import csv
import json
import os
import secrets
import threading
from pathlib import Path
from typing import Any

from bracekit._io import read_json
from bracekit.errors import InputError, OutputError
from bracekit.studies.sweep.spec import SweepSpec

#: The work folder inside OUT.
WORK = ".sweep"
#: Largest saved row or refinement read back, bytes (a row is < 4 kB).
MAX_ROW_BYTES = 1024 * 1024
#: A saved row that cannot be read (it is run again).
UNREADABLE = object()


class SweepStateError(InputError):
    """An output folder holding another sweep's partial results."""


def _write_whole(path: Path, text: str) -> None:
    """Write `text` to `path` via a temporary file in the same folder and a rename (never half a file)."""
    tmp = path.with_name(f".{path.name}.{os.getpid()}-{secrets.token_hex(4)}.tmp")
    try:
        with open(tmp, "w", encoding="utf-8") as fh:
            fh.write(text)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()


def check_work(out: Path) -> None:
    """OutputError unless ``OUT/.sweep`` and its folders, where they exist, are real folders inside OUT.

    A symbolic link there (to a folder elsewhere) is refused: bracekit writes nothing outside OUT.
    """
    root = os.path.realpath(out)
    work = Path(out) / WORK
    for folder in (work, work / "rows", work / "refined", work / "spec.json"):
        if folder.is_symlink():
            raise OutputError(
                f"{folder} is a symbolic link; bracekit writes only inside --out: remove the link or choose another "
                "--out"
            )
        if os.path.lexists(folder) and not Path(os.path.realpath(folder)).is_relative_to(root):
            raise OutputError(f"{folder} is not inside {out}; choose another --out")
        if folder.name != "spec.json" and os.path.lexists(folder) and not folder.is_dir():
            raise OutputError(f"{folder} is not a folder; move it away or choose another --out")


def check_state(out: Path, spec: SweepSpec) -> str:
    """The spec's fingerprint, after checking that ``OUT/.sweep`` (if any) holds this spec's rows; reads only.

    Raises:
        SweepStateError: the work folder was written for another spec, by another bracekit version, or from base
            scenario files that have changed since (one line saying which, and what to do).
    """
    check_work(out)
    marker = Path(out) / WORK / "spec.json"
    fingerprint = spec.fingerprint()
    if not marker.is_file():
        return fingerprint
    work = marker.parent
    try:
        held = read_json(marker, "the sweep's work file", MAX_ROW_BYTES)
        if not isinstance(held, dict):
            raise ValueError("not a JSON object")
    except ValueError as exc:
        raise SweepStateError(f"{marker} cannot be read ({exc}); give another --out or move {work} away") from exc
    if held.get("fingerprint") == fingerprint:
        return fingerprint
    parts, now = held.get("parts"), spec.fingerprint_parts()
    if not isinstance(parts, dict) and held.get("bracekit") not in (None, now["bracekit"]):
        why = f"partial results of bracekit {held.get('bracekit')} (this is {now['bracekit']}), not reused"
    elif not isinstance(parts, dict) or parts.get("spec") != now["spec"]:
        why = f"partial results of another sweep spec ({held.get('name')!r}, fingerprint {held.get('fingerprint')})"
    elif parts.get("bracekit") != now["bracekit"]:
        why = f"partial results of bracekit {parts.get('bracekit')} (this is {now['bracekit']}), not reused"
    else:
        why = "partial results from base scenario files (TOML, URDF) that have changed since, not reused"
    raise SweepStateError(f"{out} holds {why}; give another --out (or move {work} away)")


class RowStore:
    """The finished rows of a sweep in ``OUT/.sweep``; create it once the output folder is checked and locked."""

    def __init__(self, out: Path, spec: SweepSpec) -> None:
        self.work = Path(out) / WORK
        self.rows_dir = self.work / "rows"
        self.refined_dir = self.work / "refined"
        marker = self.work / "spec.json"
        fingerprint = check_state(out, spec)  # also checks the work folders (no symbolic links, inside OUT)
        try:
            self.rows_dir.mkdir(parents=True, exist_ok=True)
            self.refined_dir.mkdir(exist_ok=True)
            if not marker.is_file():
                data = {"name": spec.name, "fingerprint": fingerprint, "parts": spec.fingerprint_parts()}
                _write_whole(marker, json.dumps(data, indent=2) + "\n")
        except OSError as exc:
            raise OutputError(f"cannot write the work folder {self.work}: {exc.strerror or exc}") from exc

    def finished(self) -> dict[str, Any]:
        """Candidate id → its saved row as read (:data:`UNREADABLE` for a file that cannot be read).

        Check each with :func:`bracekit.studies.sweep.rows.row_problem` before reusing it.
        """
        return self._read(self.rows_dir)

    def refined(self) -> dict[str, dict[str, Any]]:
        """Refined candidate key → its saved refinement (JSON objects only; others are computed again)."""
        return {k: v for k, v in self._read(self.refined_dir).items() if isinstance(v, dict)}

    @staticmethod
    def _read(folder: Path) -> dict[str, Any]:
        out: dict[str, Any] = {}
        for path in sorted(folder.glob("*.json")):
            if path.is_symlink() or not path.is_file():
                out[path.stem] = UNREADABLE
                continue
            try:
                out[path.stem] = read_json(path, "a saved sweep row", MAX_ROW_BYTES)
            except InputError:
                out[path.stem] = UNREADABLE
        return out

    def save(self, row: dict[str, Any]) -> None:
        """Save a finished candidate's row (whole or not at all)."""
        _write_whole(self.rows_dir / f"{row['candidate']}.json", json.dumps(row, allow_nan=False) + "\n")

    def save_refined(self, key: str, data: dict[str, Any]) -> None:
        """Save a refinement under `key`."""
        _write_whole(self.refined_dir / f"{key}.json", json.dumps(data, allow_nan=False) + "\n")


def columns(rows: list[dict[str, Any]]) -> list[str]:
    """The columns of the rows, in the first row's order."""
    return list(rows[0]) if rows else ["candidate"]


def write_csv(rows: list[dict[str, Any]], path: Path) -> None:
    """The rows as CSV (floats written exactly, empty cells for None)."""
    names = columns(rows)
    with open(path, "w", encoding="utf-8", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(names)
        for row in rows:
            writer.writerow(
                ["" if row.get(n) is None else repr(row[n]) if isinstance(row[n], float) else row[n] for n in names]
            )


def write_parquet(rows: list[dict[str, Any]], path: Path) -> None:
    """The rows as a Parquet table (pyarrow), one column per key, nulls for None."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    names = columns(rows)
    table = pa.table({n: [row.get(n) for row in rows] for n in names})
    pq.write_table(table, path)


def import_writers() -> threading.Thread:
    """Import the Parquet writer (pyarrow, ≈ 0.1 s) in a daemon thread, while the candidates run; the thread.

    :func:`write_parquet` at the end then finds it imported (Python's import lock makes it wait for an import
    under way). Nothing else happens: a missing or broken pyarrow is reported by :func:`write_parquet`.
    """

    def load() -> None:
        try:
            import pyarrow.parquet  # noqa: F401
        except Exception:  # write_parquet reports it
            pass

    thread = threading.Thread(target=load, name="bracekit-import-writers", daemon=True)
    thread.start()
    return thread
