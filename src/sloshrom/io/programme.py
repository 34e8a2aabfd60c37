"""Drive files of a shaker programme: the CSV and UFF 58 files a shaker controller plays.

A programme (:class:`sloshrom.beam.simulation.programme.Programme`) is the commanded tank
acceleration at the virtual rig's 10 kHz integration rate. A controller takes a time history at its
own rate, so the files hold it resampled, band-limited (:func:`resample_drive`):

* **CSV** (:func:`write_drive_csv`, :func:`read_drive_csv`): the whole programme, one row per
  sample, header ``time_s,acceleration_m_s2`` (optionally ``,segment``: the 1-based segment
  number, 0 in the pauses); time with 9 decimals (ns), acceleration with 10 significant digits.
  All columns numeric, one header line, no comments: what a controller's import expects.
* **UFF 58** (:func:`drive_uff_sets`, :func:`read_drive_uff`): one time-response dataset per
  segment (ASCII, 12 significant digits, m/s^2, dataset 164 SI first), each starting at 0 s:
  each segment is its own run on the shaker (the laboratory time charges a set-up per segment);
  read back, the segments play back to back. :func:`read_drive` reads either format.

These functions work on arrays (segment names and accelerations): :mod:`sloshrom.io` sits
below the programme's module. A bad file is a :class:`~sloshrom.io.record.RecordError` whose
one line names the file, the line and the problem.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Sequence
from fractions import Fraction
from pathlib import Path

import numpy as np

from sloshrom.config import G
from sloshrom.fileio import OutputBatch, atomic_write
from sloshrom.io.record import RecordError, require_file
from sloshrom.io.uff import (
    DIR_PLUS_Z,
    SPEC_ACCELERATION,
    SPEC_TIME,
    _channel,
    _unreadable_dataset,
    dataset58,
    dataset164_si,
    open_uff,
)
from sloshrom.io.units import canonical_unit

__all__ = [
    "ACCELERATION_COLUMNS", "CSV_DECIMALS", "CSV_HEADER", "DRIVE_MARK", "UFF_SUFFIXES", "DriveFile",
    "drive_uff_sets", "exact_uff_step", "is_drive_file", "read_drive", "read_drive_csv",
    "read_drive_uff", "resample_drive", "time_decimals", "write_drive_csv",
]

#: Header of a drive CSV (the names carry the units: no brackets a controller might refuse).
CSV_HEADER = ("time_s", "acceleration_m_s2")
#: Acceleration columns :func:`read_drive_csv` accepts, with their factor to m/s^2.
ACCELERATION_COLUMNS = {"acceleration_m_s2": 1.0, "acceleration [m/s^2]": 1.0,
                        "acceleration_g": G, "acceleration [g]": G}
#: Time columns :func:`read_drive_csv` accepts.
TIME_COLUMNS = ("time_s", "time [s]")
#: ID line 5 of every dataset of a drive UFF file (:func:`drive_uff_sets`): what tells a drive
#: from a measurement (:func:`is_drive_file`).
DRIVE_MARK = "sloshrom drive file"
#: Stop-band attenuation of the resampling filter, dB: 1e-4 of a component left past the band
#: edge, below the 10 significant digits' concern but far below any shaker's control accuracy.
STOPBAND_DB = 80.0
#: Pass band of the resampling filter, fraction of the lower Nyquist frequency (the rest is
#: the transition band): 0.8 keeps 200 Hz at a 500 Hz rate, the rig sensors' own band.
PASS_FRACTION = 0.8
#: Largest denominator of the ratio of two rates that :func:`resample_drive` takes (a whole
#: number of Hz against 10 kHz always fits).
MAX_DENOMINATOR = 10_000


def _ratio(fs_in: float, fs_out: float) -> tuple[int, int]:
    """``fs_out / fs_in`` as ``(up, down)`` integers, or a RecordError."""
    ratio = Fraction(fs_out / fs_in).limit_denominator(MAX_DENOMINATOR)
    if ratio <= 0 or abs(float(ratio) * fs_in - fs_out) > 1e-9 * fs_out:
        raise RecordError(f"a rate of {fs_out:g} Hz from {fs_in:.9g} Hz is not a simple ratio: "
                          f"{fs_out:g} / {fs_in:.9g} is no fraction with a denominator up to "
                          f"{MAX_DENOMINATOR:,} (use a whole number of Hz)")
    return ratio.numerator, ratio.denominator


def resample_drive(a: np.ndarray, fs_in: float, fs_out: float) -> np.ndarray:
    """Resample a drive signal that starts and ends at rest, band-limited.

    Polyphase filtering (``scipy.signal.resample_poly``, zeros outside the signal: a drive is
    at rest before and after) with a Kaiser FIR of :data:`STOPBAND_DB` attenuation whose pass
    band is :data:`PASS_FRACTION` of the lower of the two Nyquist frequencies. ``io.resample``'s
    default filter (Kaiser, beta 5) has a pass-band ripple of a few 1e-4, seen as a 5e-4 RMS
    error on a 10 kHz -> 2 kHz -> 10 kHz round trip; this one leaves about 1e-5.

    Parameters
    ----------
    a : ndarray (n,)
        Acceleration (any unit: the operation is linear) at ``fs_in``.
    fs_in, fs_out : float
        Rates, Hz; ``fs_out / fs_in`` a fraction with denominator <= :data:`MAX_DENOMINATOR`.

    Returns
    -------
    ndarray (m,)
        ``m = round((n - 1) fs_out / fs_in) + 1`` samples: the same span of time (a last
        fraction of a step, at rest, dropped).
    """
    from scipy import signal

    a = np.asarray(a, dtype=float)
    up, down = _ratio(fs_in, fs_out)
    m = int(round((a.size - 1) * up / down)) + 1
    if up == down:
        return a.copy()
    mid = fs_in * up  # the rate the filter runs at
    nyq = 0.5 * min(fs_in, fs_out)
    width = (1.0 - PASS_FRACTION) * nyq
    numtaps, beta = signal.kaiserord(STOPBAND_DB, width / (0.5 * mid))
    numtaps |= 1  # odd: a linear-phase filter whose delay resample_poly removes exactly
    h = signal.firwin(numtaps, 0.5 * (1.0 + PASS_FRACTION) * nyq, window=("kaiser", beta),
                      fs=mid)
    out = signal.resample_poly(a, up, down, window=h)  # (it scales h by up itself)
    if out.size < m:
        out = np.concatenate([out, np.zeros(m - out.size)])
    return out[:m]


def exact_uff_step(fs: float) -> bool:
    """True if UFF's 6 significant digits of the time step give ``fs`` back to 1e-9."""
    step = float(f"{1.0 / fs:.5e}")
    return abs(1.0 / step - fs) <= 1e-9 * fs


#: Decimals of the drive CSV's acceleration (m/s^2): a resolution of 1e-6 m/s^2 (1e-7 g), below
#: the least step of a 24-bit output at +-20 g (2.4e-6 g); fixed point keeps the rests short
#: (``0.000000``), where an exponent format writes 16 characters of round-off.
CSV_DECIMALS = 6


def time_decimals(fs: float) -> int:
    """Decimals that write every time ``k / fs`` exactly (4 at 2000 Hz), 9 at most (a step
    such as 1/2048 s, written to 1e-9 s)."""
    step = 1.0 / fs
    for d in range(10):
        if abs(round(step * 10**d) - step * 10**d) <= 1e-6:
            return d
    return 9


def _csv_rows(acceleration: np.ndarray, fs: float, start: int,
              segment: np.ndarray | None) -> np.ndarray:
    time = np.arange(start, start + acceleration.size) / fs
    cols = [time, acceleration] + ([segment.astype(float)] if segment is not None else [])
    return np.column_stack(cols)


def write_drive_csv(path: str | Path, acceleration: np.ndarray, fs: float,
                    segment: np.ndarray | None = None,
                    batch: OutputBatch | None = None) -> Path:
    """Write a drive CSV (``time_s,acceleration_m_s2[,segment]``), atomically or into ``batch``.

    Parameters
    ----------
    path : str or Path
        The ``.csv`` file.
    acceleration : ndarray (n,)
        Tank vertical acceleration, m/s^2, at ``fs``; time starts at 0 s.
    fs : float
        Sample rate, Hz.
    segment : ndarray of int (n,), optional
        Segment number of each sample (1-based; 0 in a pause): the ``segment`` column.
    batch : OutputBatch, optional
        Write into this batch instead of atomically on its own.

    Returns
    -------
    Path
    """
    a = np.asarray(acceleration, dtype=float)
    if a.ndim != 1 or not np.all(np.isfinite(a)):
        raise RecordError(f"{path}: a drive must be a finite 1-D acceleration")
    if segment is not None and np.shape(segment) != a.shape:
        raise RecordError(f"{path}: one segment number per sample, got {np.shape(segment)}")
    header = ",".join(CSV_HEADER + (("segment",) if segment is not None else ()))
    fmt = (f"%.{time_decimals(fs)}f,%.{CSV_DECIMALS}f"
           + (",%d" if segment is not None else ""))

    def write(tmp: str) -> None:
        with open(tmp, "w", encoding="ascii", newline="\n") as fh:
            fh.write(header + "\n")
            step = 1 << 18  # rows per chunk: a 2 h programme never holds its text in memory
            for k in range(0, a.size, step):
                sl = slice(k, k + step)
                # + 0.0: a value that rounds to -0 is written 0
                rows = _csv_rows(np.round(a[sl], CSV_DECIMALS) + 0.0, fs, k,
                                 None if segment is None else segment[sl])
                np.savetxt(fh, rows, fmt=fmt)

    return (batch.write if batch is not None else atomic_write)(Path(path), write, ".csv")


class DriveFile:
    """A drive CSV as read by :func:`read_drive_csv`.

    Attributes
    ----------
    acceleration : ndarray (n,)
        m/s^2.
    fs : float
        Sample rate, Hz (from the uniform time column).
    segment : ndarray of int (n,) or None
        The ``segment`` column, if any.
    column : str
        The acceleration column's name (its unit).
    """

    def __init__(self, acceleration: np.ndarray, fs: float, segment: np.ndarray | None,
                 column: str) -> None:
        self.acceleration = acceleration
        self.fs = fs
        self.segment = segment
        self.column = column

    @property
    def duration(self) -> float:
        """Span of the time column, s."""
        return (self.acceleration.size - 1) / self.fs


#: Bytes read to tell a binary or UTF-16 file from text before any line is parsed.
_SNIFF = 1 << 16
_TEXT = ("a drive file is plain text (ASCII or UTF-8): the header 'time_s,acceleration_m_s2' "
         "on its first line, then one row of numbers per sample")


def _not_text(p: Path, line: int, raw: bytes, exc: UnicodeDecodeError) -> RecordError:
    """A line that is not UTF-8 (Latin-1 or another code page): its number and its first
    offending byte, and what a drive file is."""
    return RecordError(f"{p}: line {line} is not UTF-8 text (byte 0x{raw[exc.start]:02x} at "
                       f"column {exc.start + 1}): {_TEXT}")


def _header(p: Path) -> tuple[int, list[str]]:
    """The header of a drive CSV: its line number (1-based) and its column names.

    The file is read as bytes first: a binary file (a PNG renamed ``.csv``), UTF-16 text
    (NUL bytes) or a line in another encoding is a :class:`RecordError` naming it, not a
    decoding error of Python's.
    """
    with open(p, "rb") as fh:
        head = fh.read(_SNIFF)
    if b"\x00" in head or head.startswith((b"\xff\xfe", b"\xfe\xff")):
        what = ("UTF-16 text" if head.startswith((b"\xff\xfe", b"\xfe\xff"))
                else "binary data (NUL bytes; an image, a record or UTF-16 text?)")
        raise RecordError(f"{p}: {what}, not a text CSV file: {_TEXT}")
    with open(p, "rb") as fh:
        for n, raw in enumerate(fh, start=1):
            try:
                line = raw.decode("utf-8-sig" if n == 1 else "utf-8")
            except UnicodeDecodeError as exc:
                raise _not_text(p, n, raw, exc) from None
            if line.strip():
                return n, [c.strip() for c in next(csv.reader([line]))]
    raise RecordError(f"{p}: empty file, expected a header 'time_s,acceleration_m_s2'")


def _row_lines(p: Path, first: int, rows: Sequence[int]) -> list[int]:
    """The line numbers (1-based) of data rows ``rows`` (0-based) of a table whose data start
    after line ``first - 1``: blank and comment (``#``) lines hold no row, as for
    ``np.loadtxt``. Read again only when a message needs them."""
    want = sorted(set(int(r) for r in rows))
    found: dict[int, int] = {}
    k = 0
    with open(p, "rb") as fh:
        for n, raw in enumerate(fh, start=1):
            if n < first or not raw.split(b"#", 1)[0].strip():
                continue
            if k in want:
                found[k] = n
                if len(found) == len(want):
                    break
            k += 1
    return [found.get(int(r), first + int(r)) for r in rows]


def _bad_encoding(p: Path, first: int) -> RecordError:
    """The first line from ``first`` on that is not UTF-8 (the data's decoding failed)."""
    with open(p, "rb") as fh:
        for n, raw in enumerate(fh, start=1):
            if n < first:
                continue
            try:
                raw.decode("utf-8")
            except UnicodeDecodeError as exc:
                return _not_text(p, n, raw, exc)
    return RecordError(f"{p}: not UTF-8 text: {_TEXT}")


def read_drive_csv(path: str | Path) -> DriveFile:
    """Read a drive CSV: a ``time_s`` column and one acceleration column (``[g]`` allowed).

    Accepted headers: a time column (``time_s`` or ``time [s]``), an acceleration column
    (:data:`ACCELERATION_COLUMNS`: m/s^2 or g) and optionally ``segment``; comma-separated,
    one header line. Nothing in the file is evaluated.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    DriveFile
        Acceleration in m/s^2.

    Raises
    ------
    RecordError
        Naming the file and the problem: not a file or empty, not UTF-8 text (binary, UTF-16,
        a line in another encoding: its line and byte), no or unknown columns (the accepted
        ones listed), a non-numeric field (its line), NaN or infinite values (the first line),
        fewer than 2 rows, a time column that is not increasing or not uniform (the line of a
        jump, the step found and the file's; else the first line off the mean grid).
    """
    p = require_file(path)
    first, names = _header(p)
    accepted = (f"a time column ({' or '.join(TIME_COLUMNS)}) and an acceleration column "
                f"({', '.join(ACCELERATION_COLUMNS)})")
    tcol = [i for i, n in enumerate(names) if n in TIME_COLUMNS]
    acol = [i for i, n in enumerate(names) if n in ACCELERATION_COLUMNS]
    if len(tcol) != 1 or len(acol) != 1:
        raise RecordError(f"{p}: columns {names}: expected {accepted}, once each")
    unknown = [n for n in names if n not in (*TIME_COLUMNS, *ACCELERATION_COLUMNS, "segment")]
    if unknown:
        raise RecordError(f"{p}: unknown column(s) {unknown}: expected {accepted} and "
                          "optionally 'segment'")
    scol = names.index("segment") if "segment" in names else None
    try:
        data = np.loadtxt(p, delimiter=",", skiprows=first, ndmin=2, encoding="utf-8-sig")
    except UnicodeDecodeError:  # a line in another encoding after the header
        raise _bad_encoding(p, first + 1) from None
    except ValueError as exc:
        raise RecordError(f"{p}: not a numeric table after the header ({exc})") from None
    if data.shape[0] < 2 or data.shape[1] != len(names):
        raise RecordError(f"{p}: expected at least 2 rows of {len(names)} numbers, got "
                          f"{data.shape[0]} rows of {data.shape[1]}")

    def line(row: int) -> int:
        return _row_lines(p, first + 1, [row])[0]

    bad = ~np.isfinite(data).all(axis=1)
    if bad.any():
        k = int(np.argmax(bad))
        raise RecordError(f"{p}: line {line(k)}: NaN or infinite value ({data[k].tolist()}): a "
                          "drive must be finite everywhere")
    t = data[:, tcol[0]]
    dt = np.diff(t)
    if np.any(dt <= 0):
        k = int(np.argmax(dt <= 0))
        raise RecordError(f"{p}: line {line(k + 1)}: time {t[k + 1]:.9g} s does not increase "
                          f"(after {t[k]:.9g} s)")
    # the column is written with 9 decimals: 1 ns of jitter, far below any controller's step
    step = float(np.median(dt))
    tol = max(1e-6 * step, 2e-9)
    # a jump (a lost or an inserted sample, a clock that skipped) is one step unlike the
    # others: named at its own line, not where the drift it leaves crosses the tolerance
    jump = np.abs(dt - step) > tol
    if jump.any():
        k = int(np.argmax(jump))
        raise RecordError(f"{p}: line {line(k + 1)}: time {t[k + 1]:.9g} s follows "
                          f"{t[k]:.9g} s after {dt[k]:.9g} s, but the file's step is "
                          f"{step:.9g} s: a drive file needs a uniform time column")
    step = (t[-1] - t[0]) / (t.size - 1)
    off = np.abs(t - (t[0] + step * np.arange(t.size)))
    if np.any(off > tol):  # steps each within the tolerance that add up to a drift
        k = int(np.argmax(off > tol))
        raise RecordError(f"{p}: line {line(k)}: time {t[k]:.9g} s is off the uniform grid "
                          f"by {off[k]:.3g} s (mean step {step:.9g} s): a drive file needs a "
                          "uniform time column")
    fs = float(1.0 / step)
    if abs(fs - round(fs)) <= 1e-6 * fs:  # a whole number of Hz, as written
        fs = float(round(fs))
    col = names[acol[0]]
    acc = data[:, acol[0]] * ACCELERATION_COLUMNS[col]
    seg = data[:, scol].astype(int) if scol is not None else None
    return DriveFile(acc, fs, seg, col)


#: Suffixes of the UFF 58 drives :func:`read_drive` plays (any other file is a drive CSV).
UFF_SUFFIXES = (".uff", ".unv")


def read_drive_uff(path: str | Path) -> DriveFile:
    """Read a drive UFF 58 file as :func:`drive_uff_sets` writes it: its segments back to back.

    Each time-response dataset 58 (function type 1) is one segment of the programme, its own
    run on the shaker from 0 s; played in the file's order, back to back (the pauses that a
    drive CSV may hold between them are not in a UFF file). Every segment must have one rate;
    UFF stores the step with 6 significant digits, so a rate within 1e-5 of a whole number of
    Hz is taken as that number (as :func:`sloshrom.io.uff.read_uff58` does).

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    DriveFile
        Acceleration in m/s^2; ``segment`` the 1-based number of each sample's dataset.

    Raises
    ------
    RecordError
        Naming the file and the problem: not a file, not a readable UFF file, no time-response
        dataset, a dataset whose unit is not an acceleration, segments at different rates.
    """
    p = require_file(path)
    uff, types = open_uff(p)
    parts: list[np.ndarray] = []
    steps: list[float] = []
    for i, typ in enumerate(types):
        if typ != 58:
            continue
        try:
            s = uff.read_sets(i)
        except Exception as exc:  # pyuff raises bare exceptions on a damaged dataset
            raise RecordError(_unreadable_dataset(p, uff, i, typ, len(types), exc)) from exc
        if int(s.get("func_type", -1)) != 1:
            continue
        label = str(s.get("id1", "")).strip()
        where = f"{p}: dataset {i + 1} (segment {len(parts) + 1}, {label!r})"
        data, t = _channel(where, s)
        unit = str(s.get("ordinate_axis_units_lab", "") or "").strip() or "m/s^2"
        si, factor = canonical_unit(unit)
        if si != "m/s^2":
            raise RecordError(f"{where}: ordinate unit {unit!r} is not an acceleration (a "
                              "drive is the tank's acceleration, m/s^2 or g)")
        parts.append(data * factor)
        steps.append(float((t[-1] - t[0]) / (t.size - 1)))
    if not parts:
        raise RecordError(f"{p}: no time-response dataset 58: not a drive file (`sloshrom "
                          "design` writes one dataset per segment)")
    if max(steps) - min(steps) > 1e-6 * min(steps):
        raise RecordError(f"{p}: its segments have different rates ({1 / max(steps):.6g} to "
                          f"{1 / min(steps):.6g} Hz): a drive plays at one rate")
    fs = 1.0 / steps[0]
    if abs(fs - round(fs)) < 1e-5 * fs:
        fs = float(round(fs))
    segment = np.concatenate([np.full(a.size, k + 1) for k, a in enumerate(parts)])
    return DriveFile(np.concatenate(parts), fs, segment, "UFF 58 acceleration")


def is_drive_file(path: str | Path) -> bool:
    """Whether ``path`` is a drive file (a shaker's command, not a measurement): a CSV whose
    header holds a drive's columns only (:data:`TIME_COLUMNS`, :data:`ACCELERATION_COLUMNS`,
    ``segment``), or a UFF file whose first dataset 58 carries :data:`DRIVE_MARK`. A file that
    cannot be read as either is not one (its reader says why)."""
    p = Path(path)
    try:
        if p.suffix.lower() in UFF_SUFFIXES:
            uff, types = open_uff(p)
            first = next((i for i, t in enumerate(types) if t == 58), None)
            return first is not None and str(
                uff.read_sets(first, header_only=True).get("id5", "")).strip() == DRIVE_MARK
        names = _header(p)[1]
    except Exception:  # noqa: BLE001 - pyuff raises bare exceptions; unreadable: not a drive
        return False
    drive = (*TIME_COLUMNS, *ACCELERATION_COLUMNS, "segment")
    return any(n in TIME_COLUMNS for n in names) and all(n in drive for n in names)


def read_drive(path: str | Path) -> DriveFile:
    """A drive file in either format that ``sloshrom design`` writes: a UFF 58 file
    (:data:`UFF_SUFFIXES`: :func:`read_drive_uff`), else a CSV (:func:`read_drive_csv`)."""
    if Path(path).suffix.lower() in UFF_SUFFIXES:
        return read_drive_uff(path)
    return read_drive_csv(path)


def drive_uff_sets(segments: Sequence[tuple[str, np.ndarray]], fs: float, run: str
                   ) -> list[dict[str, object]]:
    """The UFF datasets of a drive: dataset 164 (SI), then one dataset 58 per segment.

    Parameters
    ----------
    segments : sequence of (name, acceleration)
        Segment name (ID line 1) and its tank acceleration, m/s^2, at ``fs``; each starts at
        0 s (its own run on the shaker).
    fs : float
        Sample rate, Hz (UFF stores the step with 6 significant digits:
        :func:`exact_uff_step`).
    run : str
        ID line 2 (the programme: configuration, split).

    Returns
    -------
    list of dict
        For :func:`sloshrom.io.uff.write_uff_sets`.
    """
    if not (math.isfinite(fs) and fs > 0):
        raise RecordError(f"fs={fs!r}: a drive's rate must be a positive number of Hz")
    sets: list[dict[str, object]] = [dataset164_si()]
    for k, (name, a) in enumerate(segments):
        sets.append(dataset58(
            np.asarray(a, dtype=float), 0.0, 1.0 / fs, id1=name, id2=run,
            id3=f"segment {k + 1} of {len(segments)}", id4=f"fs {fs:g} Hz", id5=DRIVE_MARK,
            func_type=1, func_id=k + 1, load_case_id=k + 1, rsp=("tank", 1, DIR_PLUS_Z),
            abscissa=(SPEC_TIME, "Time", "s"),
            ordinate=(SPEC_ACCELERATION, "Acceleration", "m/s^2")))
    return sets
