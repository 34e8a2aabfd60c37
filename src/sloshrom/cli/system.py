"""``sloshrom system NAME --out DIR``: the records of a benchmark system of
:data:`sloshrom.systems.SYSTEMS` (the Bouc–Wen hysteretic benchmark, ...).

The records (``train.nc``, ``validation.nc``, ``test.nc`` and the system's further tests) are
written together or not at all; ``sloshrom train`` and ``sloshrom predict`` read them with the
system's own input and output names (``--input force --output displacement``).
"""

from __future__ import annotations

import functools
import inspect
from collections.abc import Callable
from pathlib import Path
from typing import Annotated

import typer

from sloshrom.cli._app import OverwriteOpt, app, check_number, check_out, fail
from sloshrom.errors import SloshromError
from sloshrom.fileio import OutputBatch
from sloshrom.io import Record, write_record
from sloshrom.limits import MAX_SEED
from sloshrom.systems import SYSTEMS, Option, System

__all__ = ["system"]

#: How the command records its records in OUT (it replaces only those: ``check_out``'s owner).
OWNER = "sloshrom system"


def _options() -> list[inspect.Parameter]:
    """One option per keyword of the systems' generators (``--periods``, ...), each system's
    default in its help; every one defaults to None (not given)."""
    by_name: dict[str, list[tuple[System, Option]]] = {}
    for s in SYSTEMS.values():
        for o in s.options:
            by_name.setdefault(o.name, []).append((s, o))
    out = []
    for name, pairs in by_name.items():
        o0 = pairs[0][1]
        kind = int if all(isinstance(o.default, int) for _, o in pairs) else float
        if len({o.help for _, o in pairs}) == 1:
            defaults = ", ".join(f"{s.name} {o.default:g}" for s, o in pairs)
            text = f"{o0.help[:1].upper()}{o0.help[1:]} (default: {defaults})."
        else:  # one meaning (and unit) per system: each said
            text = "; ".join(f"{s.name}: {o.help} (default {o.default:g})"
                             for s, o in pairs) + "."
        out.append(inspect.Parameter(
            name, inspect.Parameter.KEYWORD_ONLY, default=None,
            annotation=Annotated[kind | None, typer.Option("--" + name.replace("_", "-"),
                                                           help=text)]))
    return out


def _write(record: Record, tmp: str) -> None:
    write_record(record, tmp)


def _system(**kw: object) -> None:
    """Write the records of a benchmark system: training, validation and test records of its
    input and output, ready for `sloshrom train` and `sloshrom predict`.

    bouc-wen: the Bouc–Wen hysteretic benchmark of Noël & Schoukens (2016), a hysteretic
    oscillator: the force on it (N) in, its displacement (m) out, at 750 Hz, simulated at 15
    kHz.
    train.nc holds 5 periods of a random-phase multisine (40 960 samples, 50 N RMS, 5-150 Hz)
    from rest with the benchmark's output noise (8e-3 mm RMS); validation.nc 2 periods of
    another; test.nc one period of a third, from rest, noiseless; test_steady.nc the same
    realisation's steady-state period (the benchmark's form of its test); sweep.nc the
    benchmark's sine sweep (40 N, 18-52 Hz at 10 Hz/min, from rest).

    cascaded-tanks: a short record, the cascaded tanks of Schoukens et al. (2016) simulated:
    pump voltage u (V) in, the lower tank's level y (V) out, Ts = 4 s, both tanks overflowing
    at 10 V, measurement noise --noise in V. train.nc holds the estimation record's first 819
    samples (from empty tanks), validation.nc the last 205 preceded by 50 samples of measured
    history (train with --history 50), test.nc 1,024 samples that start away from rest
    (predict with --history).

    The same --seed gives the same records. A record of these names in OUT that this command
    did not write (your own train.nc) is refused, named, unless --overwrite.

    Example: sloshrom system bouc-wen --out bw/ then sloshrom train --data bw/train.nc
    --validation bw/validation.nc --arch nss --input force --output displacement --out
    bw/nss.npz and sloshrom predict --model bw/nss.npz --data bw/test.nc --out bw/pred.nc
    """
    name, out, seed = str(kw.pop("name")), Path(str(kw.pop("out"))), kw.pop("seed")
    overwrite = bool(kw.pop("overwrite"))
    assert isinstance(seed, int)  # typer's conversion of --seed
    if name not in SYSTEMS:
        fail(f"no system {name!r}; the systems are {', '.join(SYSTEMS)}")
    sysm = SYSTEMS[name]
    check_number(seed, "--seed", 0, MAX_SEED)
    # the options given (typer's int or float; None: not given)
    given = {k: v for k, v in kw.items() if isinstance(v, int | float)}
    own = {o.name: o for o in sysm.options}
    for key, value in given.items():
        opt = "--" + key.replace("_", "-")
        if key not in own:
            fail(f"{opt} does not apply to the system {name}; its options are "
                 f"{', '.join('--' + o.replace('_', '-') for o in own)}")
        check_number(value, opt, own[key].lo, own[key].hi)
    check_out(out, directory=True, contents=tuple(f"{stem}.nc" for stem in sysm.records),
              owner=OWNER, overwrite=overwrite)
    try:
        records = sysm.generate(seed=seed, **given)
    except SloshromError as exc:
        fail(str(exc))
    with OutputBatch(owner=OWNER) as batch:  # all the records or none
        for stem, rec in records.items():
            batch.write(out / f"{stem}.nc", functools.partial(_write, rec), suffix=".nc")
    for stem, rec in records.items():
        what = rec.attrs.get("start", "")
        typer.echo(f"wrote {out / f'{stem}.nc'}: {len(rec)} samples at {rec.fs:g} Hz, "
                   f"{', '.join(f'{v} [{rec.units[v]}]' for v in rec.names)}"
                   + (f", {what}" if what else ""))


def _command() -> Callable[..., None]:
    """``_system`` with the signature typer reads: the system, ``--out``, ``--seed``, then one
    option per keyword of the systems' generators."""
    params = [
        inspect.Parameter("name", inspect.Parameter.KEYWORD_ONLY, annotation=Annotated[
            str, typer.Argument(help="The system: " + "; ".join(
                f"{s.name} ({s.summary})" for s in SYSTEMS.values()) + ".")]),
        inspect.Parameter("out", inspect.Parameter.KEYWORD_ONLY, annotation=Annotated[
            Path, typer.Option("--out", "-o", help="Directory of the records (created if "
                                                   "missing).")]),
        inspect.Parameter("seed", inspect.Parameter.KEYWORD_ONLY, default=0, annotation=Annotated[
            int, typer.Option(help="Seeds the excitations and the noise.")]),
        inspect.Parameter("overwrite", inspect.Parameter.KEYWORD_ONLY, default=False,
                          annotation=OverwriteOpt),
        *_options(),
    ]

    @functools.wraps(_system)
    def command(**kw: object) -> None:
        _system(**kw)

    vars(command)["__signature__"] = inspect.Signature(params)  # what typer reads
    command.__annotations__ = {p.name: p.annotation for p in params}
    command.__name__ = "system"
    return command


system = app.command(name="system")(_command())
