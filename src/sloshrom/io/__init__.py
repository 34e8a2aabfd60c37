"""Records in and out: the :class:`Record` type, units, file formats and preprocessing.

``read_record`` reads NetCDF, CSV, MATLAB (v5/v7.3) and UFF58 files into a :class:`Record`
(time on axis 0, SI units on request); ``write_record`` writes NetCDF or CSV atomically.
"""

from sloshrom.io.record import *  # noqa: F403
from sloshrom.io.record import __all__  # noqa: F401
