"""NetCDF records (``.nc``): the native format.

NetCDF-4 files are read and written with xarray/h5netcdf; NetCDF-3 ("classic" and "64-bit
offset") files are read with scipy. The conversion between a :class:`~sloshrom.io.Record` and an
``xarray.Dataset`` (units attributes, flattened attrs) is :meth:`Record.to_dataset` /
:meth:`Record.from_dataset`. xarray is imported on first use (about 1.4 s): reading a CSV file
or importing :mod:`sloshrom.io` does not pay for it.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from sloshrom.fileio import netcdf_writer
from sloshrom.io.record import Record, RecordError, _why

__all__ = ["read_netcdf", "write_netcdf"]

# NetCDF-3 "classic" (CDF\x01) and "64-bit offset" (CDF\x02) files are read with scipy;
# CDF\x05 (64-bit data, CDF-5) is not supported by scipy.
_CDF_MAGIC = {b"CDF\x01": "scipy", b"CDF\x02": "scipy"}


def read_netcdf(p: Path, fs: float | None, units: Mapping[str, str]) -> Record:
    """Read a NetCDF-3 or NetCDF-4 file (``fs``, ``units``: see :func:`sloshrom.io.read_record`)."""
    import xarray as xr

    with p.open("rb") as fh:
        magic = fh.read(4)
    if magic[:3] == b"CDF" and magic not in _CDF_MAGIC:
        raise RecordError(
            f"{p}: NetCDF-3 variant {magic!r} (CDF-5, 64-bit data) is not supported; convert it "
            "to NetCDF-4 (nccopy -k nc4 in.nc out.nc)"
        )
    engine = _CDF_MAGIC.get(magic, "h5netcdf")  # NetCDF-4 is HDF5 (also after a user block)
    # scipy: no memory map, so that nothing refers to the file once it is closed
    kw: dict[str, Any] = {"mmap": False} if engine == "scipy" else {}
    try:
        # no CF time decoding: time stays numeric (s, ms, "days since ...", ...)
        with xr.open_dataset(
            p, engine=engine, decode_times=False, decode_timedelta=False, **kw
        ) as ds:
            ds = ds.load()
    except Exception as exc:  # h5py/scipy/xarray raise many types for corrupt files
        kind = "NetCDF-3" if engine == "scipy" else "NetCDF"
        raise RecordError(f"{p}: not a readable {kind} file ({_why(exc)})") from exc
    return Record.from_dataset(ds, source=str(p), fs=fs, units=units)


def write_netcdf(record: Record, path: str) -> None:
    """Write ``record`` as NetCDF-4 to ``path`` (atomically: use write_record).

    The bytes are made in memory and written with plain I/O (:func:`sloshrom.fileio.netcdf_writer`).
    """
    netcdf_writer(record.to_dataset())(path)
