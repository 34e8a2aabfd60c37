import json

from sloshrom.stages import StageCache, atomic_write_text, stable_hash


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
