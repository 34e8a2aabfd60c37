"""Records in and out: the :class:`Record` type, units, file formats and preprocessing.

``read_record`` reads NetCDF, CSV, MATLAB (v5/v7.3) and UFF58 files into a :class:`Record`
(time on axis 0, SI units on request); ``write_record`` writes NetCDF, CSV or MATLAB atomically.

Modules: :mod:`~sloshrom.io.record` (the Record, RecordError, checks), :mod:`~sloshrom.io.units`
(unit table), one module per format (:mod:`~sloshrom.io.netcdf`, :mod:`~sloshrom.io.csv`,
:mod:`~sloshrom.io.matlab`, :mod:`~sloshrom.io.uff`), :mod:`~sloshrom.io.read` (dispatch by
suffix) and :mod:`~sloshrom.io.preprocess` (velocity, dynamic force, resampling). Imports run one
way: units <- record <- formats <- read.
"""

from sloshrom.io.preprocess import (
    dynamic_force,
    preprocess,
    record_from_measurement,
    resample,
    velocity_from_acceleration,
)
from sloshrom.io.read import read_record, write_record
from sloshrom.io.record import MAX_ABS_VALUE, Record, RecordError, require, require_unit
from sloshrom.io.units import STANDARD_UNITS, canonical_unit, is_known_unit, same_unit

__all__ = [
    "MAX_ABS_VALUE",
    "STANDARD_UNITS",
    "Record",
    "RecordError",
    "canonical_unit",
    "dynamic_force",
    "is_known_unit",
    "preprocess",
    "read_record",
    "record_from_measurement",
    "require",
    "require_unit",
    "resample",
    "same_unit",
    "velocity_from_acceleration",
    "write_record",
]
