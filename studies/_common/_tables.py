"""Helpers shared by the study scripts: one CSV writer, one markdown formatter and the process's peak memory.

Imported by path (``sys.path`` holds ``studies/`` when a script runs), with no
dependency on any study, so every study can use it without import cycles.
"""

from __future__ import annotations

import contextlib
import csv
import math
import resource
import sys
from pathlib import Path


def peak_memory_mb() -> float:
    """Peak resident memory of this process so far, in MB (``ru_maxrss``: bytes on macOS, KiB on Linux)."""
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return peak / 2**20 if sys.platform == "darwin" else peak / 1024


def write_csv(path: Path, rows: list[dict], columns: list[str] | None = None) -> Path:
    """Write ``rows`` to ``path`` (parent folders created); ``columns`` defaults to every key in order of
    appearance, and keys outside ``columns`` are left out."""
    path.parent.mkdir(parents=True, exist_ok=True)
    keys = list(columns) if columns is not None else list(dict.fromkeys(k for r in rows for k in r))
    with path.open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=keys, extrasaction="ignore")
        writer.writeheader()
        writer.writerows(rows)
    return path


@contextlib.contextmanager
def csv_rows(path: Path, columns: list[str]):
    """Write a CSV row by row: yields ``append(row)``, which writes and flushes one row, so an
    interrupted study keeps what it measured (parent folders created, header first)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(columns))
        writer.writeheader()

        def append(row: dict) -> None:
            writer.writerow(row)
            fh.flush()

        yield append


def fmt(value, spec: str = "{:.6g}") -> str:
    """``value`` formatted by ``spec``; ``-`` for None and NaN; ``str`` when ``spec`` does not apply."""
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "-"
    if isinstance(value, bool):
        return str(value)
    try:
        return spec.format(value)
    except (ValueError, TypeError):
        return str(value)


def markdown(rows: list[dict], columns: list[tuple[str, str, str]]) -> str:
    """A markdown table of ``rows`` with ``(key, header, format)`` columns (format ``"{}"``: left-aligned text)."""
    lines = ["| " + " | ".join(h for _, h, _ in columns) + " |",
             "| " + " | ".join("---" if f == "{}" else "---:" for _, _, f in columns) + " |"]
    for r in rows:
        lines.append("| " + " | ".join(fmt(r.get(k), f) for k, _, f in columns) + " |")
    return "\n".join(lines)
