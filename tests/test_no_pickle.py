"""Loading a file must never run code: no pickle anywhere in the package."""

import re
from pathlib import Path

SRC = Path(__file__).resolve().parents[1] / "src" / "sloshrom"

FORBIDDEN = [
    re.compile(r"^\s*(import|from)\s+(c?pickle|dill|cloudpickle|joblib|shelve)\b", re.M),
    re.compile(r"allow_pickle\s*=\s*True"),
    re.compile(r"\b(torch\.load|pd\.read_pickle|np\.load\([^)]*mmap)"),
]


def test_package_source_has_no_pickle():
    offenders = []
    for path in SRC.rglob("*.py"):
        text = path.read_text(encoding="utf-8")
        for pat in FORBIDDEN:
            for m in pat.finditer(text):
                offenders.append(f"{path.relative_to(SRC)}: {m.group(0).strip()}")
    assert not offenders, "pickle-like loading found:\n" + "\n".join(offenders)


def test_the_scan_sees_a_pickle_import(tmp_path):
    # the scanner itself must be able to fail
    assert FORBIDDEN[0].search("import pickle\n")
    assert FORBIDDEN[1].search("np.load(f, allow_pickle=True)")
