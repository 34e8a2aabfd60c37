import os
from pathlib import Path

import pytest

from sloshrom.fileio import atomic_write, atomic_write_text
from sloshrom.pipeline import cache as stages


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
    # the writer's process id tells a killed writer's leftover from a live one's
    assert tmp.name.startswith(f".{name}.{os.getpid()}.")
    rest = tmp.name[len(f".{name}.{os.getpid()}."):]  # random part (no dots) + suffix
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


def test_long_legal_name_gets_a_legal_temporary(tmp_path):
    from sloshrom.fileio import OutputBatch

    name = "r" * 247 + ".nc"  # 250 bytes: legal; ".{name}.XXXXXXXX.nc" would not be
    target = atomic_write(tmp_path / name, _write_text("x"))
    assert target.read_text() == "x"
    with OutputBatch() as batch:
        batch.write_text(tmp_path / ("s" * 250), "y")
    assert (tmp_path / ("s" * 250)).read_text() == "y"
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([name, "s" * 250])


def test_output_batch_all_or_nothing(tmp_path):
    from sloshrom.fileio import OutputBatch

    (tmp_path / "a.txt").write_text("old a")
    with pytest.raises(RuntimeError, match="late failure"):
        with OutputBatch() as batch:
            batch.write_text(tmp_path / "a.txt", "new a")
            batch.write_text(tmp_path / "sub" / "b.txt", "new b")
            raise RuntimeError("late failure")
    assert (tmp_path / "a.txt").read_text() == "old a"
    assert not (tmp_path / "sub" / "b.txt").exists()
    assert [p.name for p in tmp_path.rglob("*") if p.is_file()] == ["a.txt"]
    with OutputBatch() as batch:
        batch.write_text(tmp_path / "a.txt", "new a")
        batch.write_text(tmp_path / "sub" / "b.txt", "new b")
        assert not (tmp_path / "sub" / "b.txt").exists()  # nothing appears before the commit
    assert (tmp_path / "a.txt").read_text() == "new a"
    assert (tmp_path / "sub" / "b.txt").read_text() == "new b"


def test_check_output_rejects_before_any_work(tmp_path):
    from sloshrom.fileio import OutputPathError, check_output

    (tmp_path / "in.nc").write_text("data")
    (tmp_path / "afile").write_text("x")
    (tmp_path / "adir").mkdir()
    assert check_output(tmp_path / "new" / "deeper" / "o.nc", suffixes=(".nc",)) == (
        tmp_path / "new" / "deeper" / "o.nc")
    cases = [
        (dict(path=tmp_path / "o.xlsx", suffixes=(".nc", ".csv")), r"unknown format '\.xlsx'"),
        (dict(path=tmp_path / "in.nc", inputs=(tmp_path / "in.nc",)), r"also an input"),
        (dict(path=tmp_path / "." / "in.nc", inputs=(tmp_path / "in.nc",)), r"also an input"),
        (dict(path=tmp_path / "adir"), r"is a directory"),
        (dict(path=tmp_path / "afile", directory=True), r"not a directory"),
        (dict(path=tmp_path / "afile" / "o.nc"), r"afile is not a directory"),
        (dict(path=tmp_path / ("x" * 256 + ".nc")), r"longer than 255 bytes"),
    ]
    for kw, match in cases:
        path = kw.pop("path")
        with pytest.raises(OutputPathError, match=match):
            check_output(path, what="--out", **kw)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["adir", "afile", "in.nc"]


def test_failed_write_leaves_no_directory_it_created(tmp_path):
    def bad(tmp: str) -> None:
        raise OSError("disk full")

    with pytest.raises(OSError):
        atomic_write(tmp_path / "a" / "b" / "out.txt", bad)
    assert not (tmp_path / "a").exists()


def test_check_output_protects_inputs_from_everything_a_directory_gets(tmp_path):
    from sloshrom.fileio import OutputPathError, check_output

    out = tmp_path / "res"
    (out / "data").mkdir(parents=True)
    for name in ("report.html", "data/c.toml", "keep.toml"):
        (out / name).write_text("[rom]\n")
    contents = ("report.html", "data/")
    for name in ("report.html", "data/c.toml"):
        with pytest.raises(OutputPathError, match=r"--out .*res: the command writes .*, and "
                                                  rf".*{name.split('/')[-1]} is also an input"):
            check_output(out, directory=True, inputs=(out / name,), what="--out",
                         contents=contents)
    # an input beside the results, and the same names for a file output: allowed
    check_output(out, directory=True, inputs=(out / "keep.toml",), contents=contents)
    # another spelling of the same path (a symbolic link to the directory) is no way round
    (tmp_path / "link").symlink_to(out)
    with pytest.raises(OutputPathError, match=r"also an input"):
        check_output(tmp_path / "link", directory=True, inputs=(out / "data" / "c.toml",),
                     contents=contents)


def test_not_a_regular_file_says_what_it_is(tmp_path):
    import os

    from sloshrom.fileio import not_a_regular_file

    (tmp_path / "f").write_text("x")
    os.mkfifo(tmp_path / "pipe")
    (tmp_path / "dangling").symlink_to(tmp_path / "nowhere")
    assert not_a_regular_file(tmp_path / "f") is None
    assert not_a_regular_file(tmp_path / "missing") is None  # the caller says "no such file"
    assert not_a_regular_file(tmp_path) == "is a directory, expected a file"
    assert not_a_regular_file(tmp_path / "pipe").startswith("is a named pipe (FIFO)")
    assert not_a_regular_file(tmp_path / "dangling") == "a broken symbolic link"
    assert not_a_regular_file("/dev/null").startswith("is a device")


def test_a_command_replaces_only_the_files_it_wrote(tmp_path):
    """``OutputBatch(owner=)`` records what it wrote (name, size, SHA-256) in the folder's
    ``WRITTEN`` file, in the same commit; ``check_output(owner=)`` then lets the command
    replace those, and refuses, by name, a file it did not write or one changed since."""
    from sloshrom.fileio import WRITTEN, OutputBatch, OutputPathError, check_output

    d = tmp_path / "lab"
    d.mkdir()
    (d / "decay.uff").write_text("a laboratory's own data")
    (d / "notes.txt").write_text("not among what the command writes: never in question")
    names = ("decay.uff", "channels.toml")
    with pytest.raises(OutputPathError, match=r"holds decay\.uff, which cmd did not write"):
        check_output(d, directory=True, contents=names, owner="cmd")
    assert check_output(d, directory=True, contents=names, owner="cmd", overwrite=True) == d
    with OutputBatch(owner="cmd") as batch:
        for n in names:
            batch.write_text(d / n, f"{n} by cmd")
    assert sorted(p.name for p in d.iterdir()) == [WRITTEN, "channels.toml", "decay.uff",
                                                   "notes.txt"]
    check_output(d, directory=True, contents=names, owner="cmd")  # its own: replaced
    with pytest.raises(OutputPathError, match=r"which other did not write"):
        check_output(d, directory=True, contents=names, owner="other")  # not another's
    (d / "channels.toml").write_text("edited by hand")
    with pytest.raises(OutputPathError, match=r"holds channels\.toml, which cmd did not write "
                                              r"\(or that changed since\)"):
        check_output(d, directory=True, contents=names, owner="cmd")
    # a batch that fails records nothing: the previous record stands
    with pytest.raises(RuntimeError), OutputBatch(owner="cmd") as batch:
        batch.write_text(d / "channels.toml", "new")
        raise RuntimeError
    with pytest.raises(OutputPathError, match=r"channels\.toml"):
        check_output(d, directory=True, contents=names, owner="cmd")
