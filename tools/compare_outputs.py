"""Compare two ``sloshrom reproduce --out`` directories: the same files, the same numbers?

A restructure must not change results. This walks both trees and compares every result file:
NetCDF (every variable, numerically, and the attributes), CSV and Markdown tables (numbers
numerically, text exactly), JSON (``summary.json``, stage records: numbers numerically, minus
the keys that hold wall-clock times, dates, versions or paths), and lists files present in one
tree only. Figures (PNG), the HTML report and logs are listed, not compared (they embed times).

Numbers agree when ``|a - b| <= rtol * max(|a|, |b|) + atol``: ``rtol`` default 1e-9 is far
below any figure the report prints and above the last-bit differences of one machine's
thread scheduling; on one machine and one environment the chain is deterministic, so a
restructure that moves code should give 0.

Usage::

    python tools/compare_outputs.py OLD_DIR NEW_DIR [--rtol 1e-9] [--atol 1e-12]

Exit status 1 when a file differs, 0 otherwise.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import re
import sys
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

#: JSON keys whose values are times, dates, versions or locations, not results.
VOLATILE = re.compile(r"(seconds|_s$|time$|elapsed|date|created|version|path|host|python|"
                      r"started|finished|duration_wall|cache|platform|machine|cpu)", re.I)
SKIP_SUFFIXES = {".png", ".html", ".log", ".svg", ".pdf", ".npz", ".toml", ".unv", ".uff"}
#: More volatile keys in the stage records (``.stages/*.json``): the digests and sizes of the
#: files they list and the cache keys that hash them change with every run, since model files
#: and NetCDF attributes hold wall-clock times; the files themselves are compared.
STAGE_VOLATILE = re.compile(r"^(sha256|size|key)$")


def _close(a: float, b: float, rtol: float, atol: float) -> bool:
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    return abs(a - b) <= rtol * max(abs(a), abs(b)) + atol


def _worst(a: Any, b: Any) -> float:
    """Largest relative difference of two arrays (0 when equal, NaN-aware)."""
    x, y = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    both_nan = np.isnan(x) & np.isnan(y)
    d = np.where(both_nan, 0.0, np.abs(x - y))
    scale = np.maximum(np.maximum(np.abs(x), np.abs(y)), 1e-300)
    r = np.where(both_nan, 0.0, d / scale)
    return float(np.nanmax(r)) if r.size else 0.0


def compare_json(a: Any, b: Any, rtol: float, atol: float, where: str = "",
                 volatile: re.Pattern[str] | None = None) -> list[str]:
    """Differences between two JSON values (volatile keys skipped; ``volatile`` more of them)."""
    if isinstance(a, dict) and isinstance(b, dict):
        out = []
        for k in sorted(set(a) | set(b)):
            if VOLATILE.search(str(k)) or (volatile is not None and volatile.search(str(k))):
                continue
            if k not in a or k not in b:
                out.append(f"{where}.{k}: only in {'new' if k not in a else 'old'}")
                continue
            out += compare_json(a[k], b[k], rtol, atol, f"{where}.{k}", volatile)
        return out
    if isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            return [f"{where}: {len(a)} items against {len(b)}"]
        return [d for i, (x, y) in enumerate(zip(a, b, strict=True))
                for d in compare_json(x, y, rtol, atol, f"{where}[{i}]", volatile)]
    if isinstance(a, bool) or isinstance(b, bool) or not (
            isinstance(a, int | float) and isinstance(b, int | float)):
        return [] if a == b else [f"{where}: {a!r} against {b!r}"]
    return [] if _close(float(a), float(b), rtol, atol) else \
        [f"{where}: {a!r} against {b!r}"]


def _cells(path: Path) -> list[list[str]]:
    text = path.read_text(encoding="utf-8")
    if path.suffix == ".csv":
        return list(csv.reader(text.splitlines()))
    return [re.split(r"\s*\|\s*", line.strip()) for line in text.splitlines()]


def compare_table(a: Path, b: Path, rtol: float, atol: float) -> list[str]:
    """Differences between two CSV/Markdown tables, cell by cell (numbers numerically)."""
    ra, rb = _cells(a), _cells(b)
    if len(ra) != len(rb):
        return [f"{len(ra)} rows against {len(rb)}"]
    out = []
    num = re.compile(r"^[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?%?$")
    for i, (x, y) in enumerate(zip(ra, rb, strict=True)):
        if len(x) != len(y):
            out.append(f"row {i}: {len(x)} cells against {len(y)}")
            continue
        for j, (c, d) in enumerate(zip(x, y, strict=True)):
            if num.match(c) and num.match(d):
                if not _close(float(c.rstrip("%")), float(d.rstrip("%")), rtol, atol):
                    out.append(f"row {i} col {j}: {c} against {d}")
            elif c != d and not VOLATILE.search(x[0] if x else ""):
                out.append(f"row {i} col {j}: {c!r} against {d!r}")
    return out


def compare_netcdf(a: Path, b: Path, rtol: float, atol: float) -> tuple[list[str], float]:
    """Differences between two NetCDF files and the worst relative difference of a variable."""
    out, worst = [], 0.0
    with xr.open_dataset(a) as da, xr.open_dataset(b) as db:
        for name in sorted(set(da.variables) | set(db.variables)):
            if name not in da.variables or name not in db.variables:
                out.append(f"variable {name}: only in {'new' if name not in da else 'old'}")
                continue
            x, y = da[name].values, db[name].values
            if x.shape != y.shape:
                out.append(f"variable {name}: shape {x.shape} against {y.shape}")
                continue
            if x.dtype.kind in "fiuc" and y.dtype.kind in "fiuc":
                w = _worst(x, y)
                worst = max(worst, w)
                ok = np.allclose(x, y, rtol=rtol, atol=atol, equal_nan=True)
                if not ok:
                    out.append(f"variable {name}: largest relative difference {w:.3g}")
            elif not np.array_equal(x, y):
                out.append(f"variable {name}: values differ")
        attrs = compare_json(_plain(dict(da.attrs)), _plain(dict(db.attrs)), rtol, atol, "attrs")
        out += attrs
    return out, worst


def _plain(v: Any) -> Any:
    if isinstance(v, dict):
        return {k: _plain(x) for k, x in v.items()}
    if isinstance(v, np.ndarray):
        return v.tolist()
    if isinstance(v, np.generic):
        return v.item()
    if isinstance(v, str) and v[:1] in "[{":
        try:
            return json.loads(v)
        except ValueError:
            return v
    return v


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("old", type=Path)
    ap.add_argument("new", type=Path)
    ap.add_argument("--rtol", type=float, default=1e-9)
    ap.add_argument("--atol", type=float, default=1e-12)
    args = ap.parse_args(argv)
    files_a = {p.relative_to(args.old) for p in args.old.rglob("*") if p.is_file()}
    files_b = {p.relative_to(args.new) for p in args.new.rglob("*") if p.is_file()}
    bad = 0
    for rel in sorted(files_a ^ files_b):
        print(f"ONLY IN {'OLD' if rel in files_a else 'NEW'}: {rel}")
        bad += rel.suffix not in SKIP_SUFFIXES
    compared = skipped = 0
    for rel in sorted(files_a & files_b):
        a, b = args.old / rel, args.new / rel
        if rel.suffix in SKIP_SUFFIXES:
            skipped += 1
            continue
        worst = None
        if rel.suffix == ".nc":
            diffs, worst = compare_netcdf(a, b, args.rtol, args.atol)
        elif rel.suffix == ".json":
            diffs = compare_json(json.loads(a.read_text()), json.loads(b.read_text()),
                                 args.rtol, args.atol,
                                 volatile=STAGE_VOLATILE if rel.parts[0] == ".stages" else None)
        elif rel.suffix in (".csv", ".md"):
            diffs = compare_table(a, b, args.rtol, args.atol)
        else:
            skipped += 1
            continue
        compared += 1
        tag = "DIFFERS" if diffs else "same"
        extra = "" if worst is None else f" (largest relative difference {worst:.2g})"
        print(f"{tag}: {rel}{extra}")
        for d in diffs[:8]:
            print(f"    {d}")
        bad += bool(diffs)
    print(f"{compared} files compared, {skipped} not compared (figures, report, model files), "
          f"{bad} differ")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
