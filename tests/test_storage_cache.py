"""One cache root read in one place, private to the user; outputs written all or nothing."""

import json
import os
import stat
from pathlib import Path

import pytest

from geomech import _storage
from geomech.errors import InputError, NumericalError
from geomech.integrators import _codegen
from geomech.symbolic import cache as ns


def test_the_tests_never_use_the_users_cache():
    root = _storage.cache_root()
    assert root is not None and Path(os.environ["GEOMECH_TEST_ROOT"]) in root.parents
    assert Path.home() / ".cache" not in root.parents


@pytest.mark.parametrize("value", ["off", "OFF", "0", "", "none", "false"])
def test_off_disables_both_caches_and_writes_nothing_into_the_working_directory(value, monkeypatch, tmp_path):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("GEOMECH_CACHE_DIR", value)
    assert _storage.cache_root() is None and ns.cache_dir() is None
    kernels = _codegen.cache_dir()
    assert kernels.is_dir() and _storage.scratch_dir() in kernels.parents
    assert stat.S_IMODE(_storage.scratch_dir().stat().st_mode) == 0o700
    assert not list(tmp_path.iterdir())  # no ./off folder, as there once was


def test_kernels_and_derivations_share_one_root(monkeypatch, tmp_path):
    monkeypatch.setenv("GEOMECH_CACHE_DIR", str(tmp_path / "c"))
    assert _codegen.cache_dir() == tmp_path / "c" / "kernels"
    assert ns.cache_dir() == tmp_path / "c" / "derivations"


def test_a_cache_others_can_write_to_is_not_used(monkeypatch, tmp_path):
    shared = tmp_path / "shared"
    (shared / "kernels").mkdir(parents=True)
    (shared / "derivations").mkdir()
    for d in (shared / "kernels", shared / "derivations"):
        d.chmod(0o777)
    monkeypatch.setenv("GEOMECH_CACHE_DIR", str(shared))
    assert ns.cache_dir() is None
    assert shared not in _codegen.cache_dir().parents  # the private scratch directory instead


def test_the_templates_split_is_kept_beside_the_kernels_and_recomputed_when_unreadable(monkeypatch, tmp_path):
    """The split of the loop templates into shared and per-model source is read from the cache when there, and
    computed again (the same split) when its file is missing or damaged."""
    monkeypatch.setenv("GEOMECH_CACHE_DIR", str(tmp_path / "c"))
    monkeypatch.setattr(_codegen, "_template_split", _codegen._template_split.__wrapped__)
    fresh = _codegen._split_sources(_codegen._template_sources())
    assert _codegen._template_split() == fresh
    (kept,) = (tmp_path / "c" / "kernels").glob("split_*.json")
    assert json.loads(kept.read_text())[2] == list(fresh[2])
    kept.write_text(json.dumps(["shared", "model", ["a"]]))
    assert _codegen._template_split() == ("shared", "model", ("a",))  # read, not recomputed
    for damaged in ("{", json.dumps([1, 2]), json.dumps([1, "model", []])):
        kept.write_text(damaged)
        assert _codegen._template_split() == fresh
        assert json.loads(kept.read_text())[0] == fresh[0]


def test_write_set_is_all_or_nothing(tmp_path):
    out = tmp_path / "new"

    def fail(path):
        path.write_text("half")
        raise RuntimeError("disk on fire")

    with pytest.raises(RuntimeError):
        _storage.write_set(out, {"a.json": lambda p: p.write_text("{}"), "b.png": fail})
    assert not out.exists()  # made here, left empty: removed
    out.mkdir()
    (out / "a.json").write_text("old")
    with pytest.raises(RuntimeError):
        _storage.write_set(out, {"a.json": lambda p: p.write_text("new"), "b.png": fail})
    assert [p.name for p in out.iterdir()] == ["a.json"] and (out / "a.json").read_text() == "old"
    written = _storage.write_set(out, {"a.json": lambda p: p.write_text("new"), "b.txt": lambda p: p.write_text("b")})
    assert sorted(p.name for p in out.iterdir()) == ["a.json", "b.txt"] and written[0].read_text() == "new"


def test_output_directories_are_checked_before_any_work(tmp_path):
    (tmp_path / "file").write_text("")
    for bad, needle in (("", "empty"), (tmp_path / "file", "is a file"), (tmp_path / "file" / "sub", "is a file")):
        with pytest.raises(InputError, match=needle):
            _storage.check_output_dir(bad, "--out")
    assert _storage.check_output_dir(tmp_path / "a" / "b", "--out") == tmp_path / "a" / "b"
    assert not (tmp_path / "a").exists()


def test_json_refuses_nan_and_says_where():
    assert json.loads(_storage.dumps_json({"a": [1.0, 2.0]})) == {"a": [1.0, 2.0]}
    with pytest.raises(NumericalError, match=r"at b\.c\[1\]"):
        _storage.dumps_json({"a": 1.0, "b": {"c": [0.0, float("nan")]}})


def test_a_memo_keeps_the_newest_entries_and_bears_threads_that_share_it():
    store: dict = {}
    for i in range(10):
        assert _storage.remember(store, i, str(i), 4) == str(i)
    assert list(store) == [6, 7, 8, 9]  # the oldest went first
    _storage.remember(store, 7, "again", 4)  # an entry given again is the newest, and drops nothing
    assert list(store) == [6, 8, 9, 7] and store[7] == "again"
    # threads inserting into one small memo at once: no entry lost beyond the bound, no error
    import threading

    errors: list = []

    def fill(offset: int) -> None:
        try:
            for i in range(5000):
                _storage.remember(store, offset + i, i, 8)
        except Exception as exc:  # pragma: no cover - the failure this test is for
            errors.append(exc)

    threads = [threading.Thread(target=fill, args=(k * 100_000,)) for k in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors and len(store) == 8
