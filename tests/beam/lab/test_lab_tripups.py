"""What a laboratory engineer trips over, each case once (issue 53): units asked for every
channel in one message and per file, a mis-scaled station named, node numbers that change
between files, an ambiguous unit refused, band messages and table cells that say what they
mean."""

from __future__ import annotations

import csv

import numpy as np
import pytest

from sloshrom.beam.damping.analysis import AnalysisError, half_power_damping
from sloshrom.beam.lab.channels import ChannelMap, ChannelMapError, acceleration_unit
from sloshrom.beam.results import write_table


# -- units -----------------------------------------------------------------------------------------
def test_a_capital_g_is_refused_with_the_accepted_spellings():
    """``G`` is giga- in SI and a gravity unit in some software: refused, naming ``g``; the
    lower-case ``g`` and the SI spellings stay accepted."""
    why = acceleration_unit("G")
    assert why is not None and "ambiguous" in why and "'g'" in why and "m/s^2" in why
    assert acceleration_unit("g") is None and acceleration_unit("m/s2") is None
    with pytest.raises(ChannelMapError, match=r"\[units\] 'acc1': 'G' is ambiguous"):
        ChannelMap(stations=("acc1",), positions=(1.0,), units={"acc1": "G"})


# -- messages and tables ---------------------------------------------------------------------------
def test_a_band_in_a_message_has_four_significant_digits():
    """A band's edges are computed (geometric means of two modes): 16 digits say nothing."""
    f = np.linspace(0.0, 250.0, 2049)
    rising = f  # largest at the band's upper edge: no peak inside
    with pytest.raises(AnalysisError, match=r"no peak inside band 143\.1-189\.5 Hz") as err:
        half_power_damping(f, rising, (143.08389147201, 189.4827361))
    assert "143.0838" not in str(err.value)


def test_tables_keep_a_reason_s_commas_and_bars(tmp_path):
    """The CSV quotes a text with commas (every CSV reader gets the reason back whole); the
    Markdown table escapes ``|`` so that ``|H1|`` stays ``|H1|`` and the cell stays one cell."""
    reason = "low coherence at the mode: 0.43 at 12.5 Hz (the peak of |H1|, 5 % wide), below 0.5"
    rows = [{"mode": 1, "zeta": float("nan"), "reason": reason},
            {"mode": 2, "zeta": 0.0062, "reason": ""}]
    csv_path, md_path = write_table(rows, tmp_path / "t")
    with csv_path.open(newline="") as fh:
        back = list(csv.DictReader(fh))
    assert [r["reason"] for r in back] == [reason, ""]
    assert [r["mode"] for r in back] == ["1", "2"]
    line = md_path.read_text().splitlines()[2]
    assert r"the peak of \|H1\|, 5 % wide" in line
    # the row has as many cells as the header: the escaped bars split nothing
    assert line.replace(r"\|", "").count("|") == 4
