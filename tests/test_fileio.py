from pathlib import Path

import pytest

from sloshrom import stages
from sloshrom.fileio import atomic_write, atomic_write_text


def _write_text(content: str):
    def write(tmp: str) -> None:
        Path(tmp).write_text(content, encoding="utf-8")

    return write


def test_success_writes_file_creates_parent_and_leaves_no_temporary(tmp_path):
    target = tmp_path / "sub" / "out.txt"
    assert atomic_write(target, _write_text("hello")) == target
    assert target.read_text(encoding="utf-8") == "hello"
    assert [p.name for p in target.parent.iterdir()] == ["out.txt"]


def test_failing_writer_keeps_previous_content_and_leaves_no_temporary(tmp_path):
    target = tmp_path / "out.txt"
    target.write_text("old", encoding="utf-8")

    def bad(tmp: str) -> None:
        Path(tmp).write_text("half", encoding="utf-8")
        raise RuntimeError("writer failed")

    with pytest.raises(RuntimeError, match="writer failed"):
        atomic_write(target, bad)
    assert target.read_text(encoding="utf-8") == "old"
    assert [p.name for p in tmp_path.iterdir()] == ["out.txt"]


def test_interrupt_in_writer_also_cleans_up(tmp_path):
    target = tmp_path / "out.txt"

    def interrupted(tmp: str) -> None:
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        atomic_write(target, interrupted)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(("name", "suffix", "expected"), [
    ("fig.png", None, ".png"),  # default: the target's suffix
    ("model.bin", ".onnx", ".onnx"),
    ("noext", None, ""),
])
def test_suffix_is_passed_to_the_temporary(tmp_path, name, suffix, expected):
    seen = []

    def write(tmp: str) -> None:
        seen.append(Path(tmp))
        Path(tmp).write_bytes(b"x")

    target = tmp_path / name
    atomic_write(target, write, suffix=suffix)
    (tmp,) = seen
    assert tmp.parent == tmp_path
    assert tmp.name.startswith(f".{name}.")
    rest = tmp.name[len(f".{name}."):]  # random part (no dots) + suffix
    assert rest.endswith(expected) and "." not in rest[: len(rest) - len(expected)]
    assert target.read_bytes() == b"x" and not tmp.exists()


def test_atomic_write_text(tmp_path):
    target = tmp_path / "a" / "b.json"
    assert atomic_write_text(target, "{\"µ\": 1}\n") == target
    assert target.read_text(encoding="utf-8") == "{\"µ\": 1}\n"
    assert [p.name for p in target.parent.iterdir()] == ["b.json"]
    assert stages.atomic_write_text is atomic_write_text  # still importable from stages


def test_written_file_has_umask_permissions(tmp_path):
    import os

    from sloshrom.fileio import atomic_write_text

    old = os.umask(0o022)
    try:
        p = atomic_write_text(tmp_path / "r.txt", "x")
    finally:
        os.umask(old)
    assert (p.stat().st_mode & 0o777) == 0o644
