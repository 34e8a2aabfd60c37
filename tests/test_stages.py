import hashlib
import json

import pytest

from sloshrom.pipeline.cache import StageCache, atomic_write_text, file_sha256, stable_hash


def test_stage_reused_only_when_key_and_files_match(tmp_path):
    cache = StageCache(tmp_path)
    calls = []

    def work():
        calls.append(1)
        atomic_write_text(tmp_path / "a.txt", "x")
        return {"value": 3}, ["a.txt"]

    r1 = cache.run("a", {"p": 1}, [], work)
    r2 = cache.run("a", {"p": 1}, [], work)
    assert not r1.reused and r2.reused and r2.outputs == {"value": 3} and len(calls) == 1
    r3 = cache.run("a", {"p": 2}, [], work)  # config changed
    assert not r3.reused and len(calls) == 2
    (tmp_path / "a.txt").unlink()  # output deleted
    assert not cache.run("a", {"p": 2}, [], work).reused and len(calls) == 3
    # a downstream stage reruns when its dependency's key changes
    b1 = cache.run("b", {}, [r3], lambda: ({}, []))
    b2 = cache.run("b", {}, [r1], lambda: ({}, []))
    assert not b1.reused and not b2.reused and b1.key != b2.key


def test_a_stage_finds_its_inputs_in_the_records(tmp_path):
    """A result lists the files its stage recorded; a later stage takes them from there."""
    cache = StageCache(tmp_path)

    def work():
        atomic_write_text(tmp_path / "data" / "train.nc", "x")
        return {"n": 1}, ["data/train.nc", "data/train.nc"]

    first = cache.run("data", {}, [], work)
    again = cache.run("data", {}, [], work)
    for res in (first, again, cache.recorded("data")):
        assert res.files == ("data/train.nc",)
        assert res.output("data/train.nc") == tmp_path / "data" / "train.nc"
        assert res.optional_output("data/validation.nc") is None
        with pytest.raises(KeyError, match="stage 'data' recorded no file 'data/other.nc'"):
            res.output("data/other.nc")
    assert cache.recorded("rom") is None
    (tmp_path / "data" / "train.nc").write_text("changed")  # not the recorded content
    assert cache.recorded("data") is None


def test_interrupted_stage_is_not_recorded(tmp_path):
    cache = StageCache(tmp_path)

    def boom():
        raise KeyboardInterrupt

    try:
        cache.run("a", {}, [], boom)
    except KeyboardInterrupt:
        pass
    assert not (tmp_path / ".stages" / "a.json").exists()


def test_stable_hash_is_order_independent():
    assert stable_hash({"a": 1, "b": [1, 2]}) == stable_hash({"b": [1, 2], "a": 1})
    assert stable_hash({"a": 1}) != stable_hash({"a": 1.5})


def test_atomic_write_leaves_no_temporary(tmp_path):
    atomic_write_text(tmp_path / "x.json", json.dumps({"a": 1}))
    assert [p.name for p in tmp_path.iterdir()] == ["x.json"]


# -- content hashes: a stage is reused only if its files are byte-for-byte what it wrote --------
def _counting_stage(root, name="a.bin", content=b"0123456789" * 1000):
    calls = []

    def work():
        calls.append(1)
        atomic_write_text(root / "sub" / name, content.decode())
        return {"n": len(calls)}, [f"sub/{name}"]

    return work, calls


def test_untouched_outputs_are_reused_and_the_record_holds_hashes(tmp_path):
    cache = StageCache(tmp_path)
    work, calls = _counting_stage(tmp_path)
    first = cache.run("a", {}, [], work)
    again = cache.run("a", {}, [], work)
    assert not first.reused and again.reused and len(calls) == 1
    assert again.digest == first.digest != ""
    rec = json.loads((tmp_path / ".stages" / "a.json").read_text())
    entry = rec["files"]["sub/a.bin"]
    assert entry["size"] == 10_000
    assert entry["sha256"] == hashlib.sha256(b"0123456789" * 1000).hexdigest()


def test_emptied_output_is_redone(tmp_path):
    cache = StageCache(tmp_path)
    work, calls = _counting_stage(tmp_path)
    cache.run("a", {}, [], work)
    (tmp_path / "sub" / "a.bin").write_bytes(b"")
    res = cache.run("a", {}, [], work)
    assert not res.reused and len(calls) == 2
    assert (tmp_path / "sub" / "a.bin").stat().st_size == 10_000  # rewritten


def test_swapped_output_of_the_same_size_is_redone(tmp_path):
    cache = StageCache(tmp_path)
    work, calls = _counting_stage(tmp_path)
    cache.run("a", {}, [], work)
    p = tmp_path / "sub" / "a.bin"
    data = bytearray(p.read_bytes())
    data[5000] ^= 0x01  # one bit, same size, same modification-time resolution
    p.write_bytes(bytes(data))
    assert not cache.run("a", {}, [], work).reused and len(calls) == 2
    assert cache.run("a", {}, [], work).reused and len(calls) == 2


def test_old_record_without_hashes_is_not_trusted(tmp_path):
    cache = StageCache(tmp_path)
    work, calls = _counting_stage(tmp_path)
    first = cache.run("a", {}, [], work)
    # the layout written before content hashes: file names only
    old = {"name": "a", "key": first.key, "outputs": {"n": 1}, "files": ["sub/a.bin"]}
    (tmp_path / ".stages" / "a.json").write_text(json.dumps(old))
    assert cache.lookup("a", first.key) is None
    assert not cache.run("a", {}, [], work).reused and len(calls) == 2


def test_record_cannot_point_outside_the_root(tmp_path):
    root = tmp_path / "out"
    cache = StageCache(root)
    (tmp_path / "secret").write_text("x")
    rec = {"record_version": 2, "name": "a", "key": "k", "outputs": {},
           "files": {"../secret": {"size": 1, "sha256": hashlib.sha256(b"x").hexdigest()}}}
    atomic_write_text(root / ".stages" / "a.json", json.dumps(rec))
    assert cache.lookup("a", "k") is None
    with pytest.raises(ValueError, match="not a path inside"):
        cache.store("b", "k", {}, ["../secret"])


def test_redone_upstream_with_new_content_redoes_downstream(tmp_path):
    cache = StageCache(tmp_path)
    content = {"v": "one"}

    def up():
        atomic_write_text(tmp_path / "up.txt", content["v"])
        return {}, ["up.txt"]

    down_calls = []

    def down():
        down_calls.append(1)
        return {}, []

    u1 = cache.run("up", {}, [], up)
    cache.run("down", {}, [u1], down)
    u2 = cache.run("up", {}, [], up)
    assert u2.reused and cache.run("down", {}, [u2], down).reused and len(down_calls) == 1
    # the upstream file is swapped: upstream is redone (same config, so the same key) and
    # produces other content; downstream must not be reused on the strength of the key alone
    (tmp_path / "up.txt").write_text("tampered")
    content["v"] = "two"
    u3 = cache.run("up", {}, [], up)
    assert not u3.reused and u3.key == u1.key and u3.digest != u1.digest
    assert not cache.run("down", {}, [u3], down).reused and len(down_calls) == 2


def test_file_sha256_streams(tmp_path):
    p = tmp_path / "big.bin"
    data = bytes(range(256)) * 20_000  # 5 MB: several chunks
    p.write_bytes(data)
    assert file_sha256(p) == hashlib.sha256(data).hexdigest()
