"""A laboratory's campaign folder: which files are free decays and which the levels of a random
test, from a small manifest or from the files' content.

* :func:`campaign_tests` - the tests of a folder (:class:`CampaignTest`): the manifest
  ``campaign.toml`` when the folder has one, else every data file classified by its content.
* :data:`MANIFEST` - the manifest's name; its format::

      [[test]]
      file = "decay_1.uff"          # or files = ["r01.uff", "r02.uff"] for a random test
      kind = "free"                 # "free" or "random"
      name = "decay1"               # optional: the case name (default the file's stem)
      levels = [0.1, 0.2]           # optional, random: RMS base levels, g, one per file

Without a manifest, a file whose channels include the map's ``base`` and whose base is random
(:func:`sloshrom.beam.lab.measured.check_random_base`) is a level of the random test; any other file
is a free decay, except a shaker's drive file (:func:`sloshrom.io.programme.is_drive_file`: the
files `sloshrom design` writes), which is left out with a note. A manifest names files of the
folder only (relative names without ``..``). Reads files, analyses nothing.
"""

from __future__ import annotations

import re
import warnings
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path, PurePath

from sloshrom.beam.damping.analysis import AnalysisError
from sloshrom.beam.errors import BeamError
from sloshrom.beam.lab.channels import ChannelMap
from sloshrom.beam.lab.measured import check_random_base, read_random_test
from sloshrom.config import ConfigError, load_toml_table
from sloshrom.errors import Note
from sloshrom.io.programme import is_drive_file
from sloshrom.io.record import RecordError

__all__ = ["DATA_SUFFIXES", "MANIFEST", "CampaignError", "CampaignTest", "campaign_tests"]

#: The manifest of a campaign folder.
MANIFEST = "campaign.toml"
#: Data files of a campaign folder (UFF 58, CSV, NetCDF, MATLAB).
DATA_SUFFIXES = (".uff", ".unv", ".csv", ".nc", ".mat")
_NAME = re.compile(r"[^A-Za-z0-9_.-]+")


class CampaignError(ConfigError, BeamError):
    """A campaign folder or its manifest is invalid (no tests, unknown keys, missing files)."""


@dataclass(frozen=True)
class CampaignTest:
    """One test of a campaign.

    Attributes
    ----------
    kind : {"free", "random"}
    name : str
        Case name (letters, digits, ``-_.``).
    files : tuple of Path
        One file for a free decay, one per level for a random test.
    levels : tuple of float or None
        Random tests: the RMS base levels, g, if given.
    how : str
        ``"manifest"`` or ``"content"``.
    """

    kind: str
    name: str
    files: tuple[Path, ...]
    levels: tuple[float, ...] | None = None
    how: str = "content"


def _case(stem: str) -> str:
    return _NAME.sub("_", stem).strip("_") or "test"


def _from_manifest(directory: Path, table: object) -> list[CampaignTest]:
    where = str(directory / MANIFEST)
    if not isinstance(table, list) or not table:
        raise CampaignError(f"{where}: give the tests as [[test]] tables")
    out = []
    for i, t in enumerate(table, start=1):
        if not isinstance(t, Mapping):
            raise CampaignError(f"{where}: test {i} is not a table")
        unknown = sorted(set(t) - {"file", "files", "kind", "name", "levels"})
        if unknown:
            raise CampaignError(f"{where}: test {i}: unknown key(s) {', '.join(unknown)} "
                                "(known: file, files, kind, name, levels)")
        kind = t.get("kind")
        if kind not in ("free", "random"):
            raise CampaignError(f"{where}: test {i}: kind must be 'free' or 'random', got "
                                f"{kind!r}")
        if ("file" in t) == ("files" in t):
            raise CampaignError(f"{where}: test {i}: give 'file' or 'files'")
        names = [t["file"]] if "file" in t else t["files"]
        if not isinstance(names, list) or not names or not all(
                isinstance(n, str) and n for n in names):
            raise CampaignError(f"{where}: test {i}: 'files' must be a list of file names")
        for n in names:  # a campaign is its folder: no file outside it
            rel = PurePath(n)
            if rel.is_absolute() or ".." in rel.parts:
                raise CampaignError(f"{where}: test {i}: file {n!r} is outside the campaign "
                                    f"folder {directory}: name its files relative to it, "
                                    "without '..'")
        if kind == "free" and len(names) != 1:
            raise CampaignError(f"{where}: test {i}: a free decay is one file")
        files = tuple(directory / n for n in names)
        for f in files:
            if not f.is_file():
                raise CampaignError(f"{where}: test {i}: no file {f}")
        levels = t.get("levels")
        if levels is not None:
            if kind != "random" or not isinstance(levels, list) or len(levels) != len(files) \
                    or not all(isinstance(v, int | float) and not isinstance(v, bool) and v > 0
                               for v in levels):
                raise CampaignError(f"{where}: test {i}: 'levels' are a random test's RMS "
                                    "levels, g, one positive number per file")
            levels = tuple(float(v) for v in levels)
        name = t.get("name", _case(files[0].stem) if kind == "free" else "random")
        if not isinstance(name, str) or _case(name) != name:
            raise CampaignError(f"{where}: test {i}: name {name!r}: letters, digits, '-', '_' "
                                "and '.' only")
        out.append(CampaignTest(kind, name, files, levels, "manifest"))
    return out


def _is_random(path: Path, channels: ChannelMap, units: Mapping[str, str] | None) -> bool:
    if channels.base is None:
        return False
    try:
        res = read_random_test([path], channels, None, units=units, levels=[1.0])
    except RecordError as exc:
        if f"no channel {channels.base!r}" in str(exc):
            return False  # a decay need not have the base channel
        raise
    try:
        check_random_base(res["base_acceleration"][0], res["fs"])
    except AnalysisError:
        return False
    return True


def campaign_tests(directory: str | Path, channels: ChannelMap,
                   units: Mapping[str, str] | None = None) -> list[CampaignTest]:
    """The tests of a campaign folder, free decays first (by name), then the random test.

    Parameters
    ----------
    directory : path
        The folder (not searched recursively).
    channels : ChannelMap
        The campaign's channel map (one for every test).
    units : mapping, optional
        Units of channels whose files give none.

    Raises
    ------
    CampaignError
        No data file, a bad manifest, or two free decays with the same case name.
    RecordError
        A file that cannot be read with the map.
    """
    d = Path(directory)
    if not d.is_dir():
        raise CampaignError(f"{d} is not a folder")
    if (d / MANIFEST).is_file():
        try:
            tests = _from_manifest(d, load_toml_table(d / MANIFEST, "test", CampaignError))
        except CampaignError:
            raise
        except ConfigError as exc:
            raise CampaignError(str(exc)) from None
    else:
        files = sorted(p for p in d.iterdir()
                       if p.is_file() and p.suffix.lower() in DATA_SUFFIXES)
        # a shaker's drive files (`sloshrom design`'s, written beside the tests) are commands,
        # not measurements: left out, and said
        drives = [p for p in files if is_drive_file(p)]
        if drives:
            warnings.warn(Note(f"{d}: {', '.join(p.name for p in drives)}: drive file(s) of "
                               "a shaker programme (`sloshrom design`), not measured tests: "
                               "left out"), stacklevel=2)
            files = [p for p in files if p not in drives]
        if not files:
            raise CampaignError(f"{d} holds no data file ({', '.join(DATA_SUFFIXES)}) and no "
                                f"{MANIFEST}")
        rnd = [p for p in files if _is_random(p, channels, units)]
        tests = [CampaignTest("free", _case(p.stem), (p,)) for p in files if p not in rnd]
        if rnd:
            tests.append(CampaignTest("random", "random", tuple(rnd)))
    names = [t.name for t in tests]
    dup = next((n for n in names if names.count(n) > 1), None)
    if dup is not None:
        raise CampaignError(f"{d}: two tests are named {dup!r}: name them in {MANIFEST}")
    return sorted(tests, key=lambda t: (t.kind != "free", t.name))
