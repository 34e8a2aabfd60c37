"""Time the benchmarks of two checkouts in the same run: is every one within 10 % of before?

The old revision (default ``8b32580``, the commit before the package moved into rooms) is checked
out into a temporary ``git worktree``; each benchmark script is then run from *each* checkout
with that checkout's own code (``PYTHONPATH=<checkout>/src``, the same interpreter), old and new
interleaved (old, new, new, old, ...) so that a drift of the machine's load hits both alike. The
figure is the wall-clock time of the whole script (minimum over ``--repeat`` runs, after one
untimed warm-up run per checkout that fills the numba and JAX caches); ``--figures`` also lists
the timings the scripts print themselves, line by line.

Usage::

    .venv/bin/python benchmarks/compare_checkouts.py                      # all, full size
    .venv/bin/python benchmarks/compare_checkouts.py --quick --repeat 3   # reduced sizes
    .venv/bin/python benchmarks/compare_checkouts.py --quick --bench damping_estimators

Exit status 1 if a benchmark of the new checkout is more than ``--tolerance`` slower.
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

HERE = Path(__file__).resolve().parent
NEW = HERE.parent
OLD_REV = "8b32580"

#: The benchmarks and their arguments: (full size, ``--quick``). Scripts without options always
#: run at full size.
BENCHMARKS: dict[str, tuple[list[str], list[str]]] = {
    "rig_speed": ([], []),
    "beam_speed": ([], []),
    "train_speed": ([], ["--train-duration", "60", "--val-duration", "30", "--max-epochs", "50",
                         "--skip-baselines"]),
    "damping_estimators": ([], ["--seeds", "5"]),
}

_TIMING = re.compile(r"(\d+(?:\.\d+)?)\s*(ms|s)\b")


@dataclass
class Runs:
    """Wall-clock times (s) and the output of the last run of one benchmark in one checkout."""

    seconds: list[float] = field(default_factory=list)
    output: str = ""

    @property
    def best(self) -> float:
        return min(self.seconds)


def _git(*args: str, cwd: Path = NEW) -> str:
    return subprocess.run(["git", *args], cwd=cwd, check=True, capture_output=True,
                           text=True).stdout.strip()


def _env(checkout: Path) -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = str(checkout / "src")
    return env


def _check_imports_from(checkout: Path) -> None:
    """The interpreter must import ``sloshrom`` from ``checkout``, not from an installed copy."""
    where = subprocess.run([sys.executable, "-c", "import sloshrom; print(sloshrom.__file__)"],
                           env=_env(checkout), check=True, capture_output=True, text=True,
                           cwd=tempfile.gettempdir()).stdout.strip()
    if not Path(where).resolve().is_relative_to((checkout / "src").resolve()):
        raise SystemExit(f"PYTHONPATH={checkout}/src imports sloshrom from {where}")


def _run(checkout: Path, name: str, args: list[str], workdir: Path) -> tuple[float, str]:
    script = checkout / "benchmarks" / f"{name}.py"
    t0 = time.perf_counter()
    res = subprocess.run([sys.executable, str(script), *args], env=_env(checkout), cwd=workdir,
                         capture_output=True, text=True)
    seconds = time.perf_counter() - t0
    if res.returncode != 0:
        raise SystemExit(f"{script} failed (exit {res.returncode}):\n{res.stdout}\n{res.stderr}")
    return seconds, res.stdout


def compare(name: str, args: list[str], old: Path, new: Path, repeat: int, warmup: bool,
            workdir: Path) -> dict[str, Runs]:
    """Run one benchmark in both checkouts, interleaved; returns the runs by checkout."""
    runs = {"old": Runs(), "new": Runs()}
    where = {"old": old, "new": new}
    if warmup:
        for label in ("old", "new"):
            _run(where[label], name, args, workdir)
    for i in range(repeat):
        for label in ("old", "new") if i % 2 == 0 else ("new", "old"):
            seconds, out = _run(where[label], name, args, workdir)
            runs[label].seconds.append(seconds)
            runs[label].output = out
            print(f"  {name} [{label}] run {i + 1}: {seconds:.2f} s", flush=True)
    return runs


def printed_figures(old: str, new: str) -> list[str]:
    """The timings the script printed, paired by line where the two lines' words agree."""
    rows = []
    for a, b in zip(old.splitlines(), new.splitlines(), strict=False):
        if _TIMING.sub("#", a) != _TIMING.sub("#", b):
            continue
        for (va, ua), (vb, ub) in zip(_TIMING.findall(a), _TIMING.findall(b), strict=True):
            ta, tb = (float(va) * (1e-3 if ua == "ms" else 1.0),
                      float(vb) * (1e-3 if ub == "ms" else 1.0))
            ratio = f"{tb / ta:6.2f}" if ta > 0 else "     -"
            rows.append(f"    {ta:10.4g} s {tb:10.4g} s {ratio}  {a.strip()[:60]}")
    return rows


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--old", default=OLD_REV, help=f"git revision to compare with ({OLD_REV})")
    ap.add_argument("--new", type=Path, default=NEW, help="checkout to test (this one)")
    ap.add_argument("--bench", action="append", choices=sorted(BENCHMARKS),
                    help="a benchmark to run (repeatable; default: all)")
    ap.add_argument("--quick", action="store_true", help="reduced sizes where a script has them")
    ap.add_argument("--repeat", type=int, default=1, help="timed runs per checkout (minimum)")
    ap.add_argument("--no-warmup", dest="warmup", action="store_false",
                    help="skip the untimed first run of each checkout")
    ap.add_argument("--tolerance", type=float, default=0.10, help="allowed slow-down (0.10)")
    ap.add_argument("--figures", action="store_true", help="also compare the printed timings")
    args = ap.parse_args(argv)
    names = args.bench or list(BENCHMARKS)
    new = args.new.resolve()
    rev = _git("rev-parse", "--short", args.old, cwd=new)

    with tempfile.TemporaryDirectory(prefix="sloshrom-compare-") as tmp:
        old = Path(tmp) / f"old-{rev}"
        workdir = Path(tmp) / "work"
        workdir.mkdir()
        _git("worktree", "add", "--detach", str(old), rev, cwd=new)
        try:
            for checkout in (old, new):
                _check_imports_from(checkout)
            print(f"old: {rev} ({old}); new: {new} ({_git('rev-parse', '--short', 'HEAD', cwd=new)}"
                  f"{', uncommitted changes' if _git('status', '--porcelain', cwd=new) else ''}); "
                  f"python {sys.executable}", flush=True)
            results = {}
            for name in names:
                bench_args = BENCHMARKS[name][1 if args.quick else 0]
                results[name] = compare(name, bench_args, old, new, args.repeat, args.warmup,
                                        workdir)
        finally:
            _git("worktree", "remove", "--force", str(old), cwd=new)

    print(f"\n{'benchmark':20s} {'old s':>9s} {'new s':>9s} {'new/old':>8s}  verdict "
          f"(within {100 * args.tolerance:g} %)")
    failed = []
    for name, runs in results.items():
        ratio = runs["new"].best / runs["old"].best
        ok = ratio <= 1.0 + args.tolerance
        failed += [] if ok else [name]
        print(f"{name:20s} {runs['old'].best:9.2f} {runs['new'].best:9.2f} {ratio:8.3f}  "
              f"{'ok' if ok else 'SLOWER'}")
        if args.figures:
            print("\n".join(printed_figures(runs["old"].output, runs["new"].output)))
    print("\nverdict: " + (f"{len(failed)} slower than allowed: {', '.join(failed)}" if failed
                           else f"every benchmark within {100 * args.tolerance:g} %"))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
