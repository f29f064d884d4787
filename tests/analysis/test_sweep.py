"""Studies over many parameter values on dask (geomech.analysis.sweep): a grid and random samples, each block of
members one ensemble call written into a Zarr store; interrupted and resumed, and on a cluster that loses a worker,
they end with the data of an uninterrupted serial run, to the last bit."""

import json
import os
import signal
import sys
import threading
import time

import numpy as np
import pytest

import geomech as gm
from geomech.analysis.sweep import SEED_BLOCK, draw, monte_carlo, sweep
from geomech.errors import InputError

BODY = gm.RigidBody([3.0, 2.0, 1.0])
M0 = np.array([1.0, 0.3, 0.2])
CALLS: list[int] = []


def trig(a, b, scale=1.0):
    CALLS.append(len(a))
    return {"f": scale * np.sin(a) * b, "pair": np.stack([a, b * 2], axis=-1), "big": a > 0.5}


def spin_up(I1, I2, threads=1):
    """The free body's momentum at t = 3 for a batch of inertias: one compiled call for the block."""
    sol = gm.solve(
        BODY,
        "dop853",
        m0=M0,
        t_final=3.0,
        saveat=[3.0],
        parameters={"I1": I1, "I2": I2},
        rtol=1e-10,
        atol=1e-12,
        threads=threads,
    )
    return {"m": sol.m[:, -1], "energy": sol.energy[:, -1]}


def test_a_grid_study_is_the_function_on_the_grid(tmp_path):
    a, b = np.linspace(0.0, 1.0, 30), np.linspace(1.0, 2.0, 7)
    CALLS.clear()
    ds = sweep(trig, a=a, b=b, chunk=16, fixed={"scale": 2.0}, units={"f": "m", "a": "rad"}, out=tmp_path / "s.zarr")
    A, B = np.meshgrid(a, b, indexing="ij")
    assert ds["f"].dims == ("a", "b") and ds["pair"].dims == ("a", "b", "pair_dim0")
    np.testing.assert_array_equal(ds["f"].values, 2.0 * np.sin(A) * B)
    np.testing.assert_array_equal(ds["pair"].values[..., 1], 2 * B)
    np.testing.assert_array_equal(ds["big"].values, A > 0.5)
    assert (ds["status"].values == 0).all()
    assert ds["f"].attrs["units"] == "m" and ds["a"].attrs["units"] == "rad"
    assert "tests.analysis.test_sweep.trig" in ds.attrs["provenance"] or "test_sweep.trig" in ds.attrs["provenance"]
    assert {"geomech", "numpy", "dask", "zarr"} <= set(json.loads(ds.attrs["versions"]))
    ds.to_netcdf(tmp_path / "s.nc")  # the provenance travels with the data
    # one call per block of at most 16 members (plus the one-member probe of the outputs): ensembles, not members
    assert CALLS[0] == 1 and max(CALLS[1:]) <= 16 and len(CALLS) - 1 == int(np.ceil(30 / 2))


def test_each_block_is_one_compiled_ensemble_of_the_members():
    I1, I2 = np.linspace(2.2, 2.7, 6), np.array([1.8, 2.2])
    ds = sweep(spin_up, I1=I1, I2=I2, chunk=4)
    for i, j in [(0, 0), (5, 1), (2, 1)]:
        one = gm.solve(
            gm.RigidBody([I1[i], I2[j], 1.0]), "dop853", m0=M0, t_final=3.0, saveat=[3.0], rtol=1e-10, atol=1e-12
        )
        np.testing.assert_allclose(ds["m"].values[i, j], one.m[-1], rtol=0, atol=1e-9)
        np.testing.assert_allclose(ds["energy"].values[i, j], one.energy[-1], rtol=0, atol=1e-9)


def test_random_samples_do_not_depend_on_the_chunking(tmp_path):
    spec = dict(I1=("normal", 2.6, 0.05), I2=("uniform", 1.9, 2.1))
    n = SEED_BLOCK + 300  # across two generation blocks
    small = monte_carlo(spin_up, n, seed=11, chunk=700, out=tmp_path / "a.zarr", **spec)
    large = monte_carlo(spin_up, n, seed=11, chunk=3000, **spec)
    for name in ("I1", "I2", "m", "energy"):
        np.testing.assert_array_equal(small[name].values, large[name].values)
    drawn = draw({"I1": ("normal", 2.6, 0.05), "I2": ("uniform", 1.9, 2.1)}, 11, 0, n)
    np.testing.assert_array_equal(small["I1"].values, drawn["I1"])
    assert abs(float(small["I1"].std()) - 0.05) < 0.005 and json.loads(small.attrs["geomech_study"])["seed"] == 11
    other = draw({"I1": ("normal", 2.6, 0.05), "I2": ("uniform", 1.9, 2.1)}, 12, 0, 10)
    assert not np.array_equal(other["I1"], drawn["I1"][:10])


class Interrupted(BaseException):
    """What Ctrl-C is to a study: not an error of a member, the end of the run."""


BUDGET: list[int] = []
DONE: list[int] = []


def fragile(a, b):
    if BUDGET and len(DONE) >= BUDGET[0]:
        raise Interrupted
    DONE.append(len(a))
    return {"f": np.cos(a) + b**2}


def test_an_interrupted_study_resumes_to_the_same_data(tmp_path):
    axes = dict(a=np.linspace(0.0, 3.0, 40), b=np.linspace(-1.0, 1.0, 9))
    whole = sweep(fragile, chunk=27, **axes)  # 40 x 9 in blocks of 3 x 9: 14 blocks
    BUDGET[:] = [6]
    DONE.clear()
    store = tmp_path / "study.zarr"
    with pytest.raises(Interrupted):
        sweep(fragile, chunk=27, out=store, **axes)
    BUDGET.clear()
    with pytest.raises(InputError, match="exists: pass resume=True"):
        sweep(fragile, chunk=27, out=store, **axes)
    with pytest.raises(InputError, match="holds another study"):
        sweep(fragile, chunk=27, out=store, resume=True, a=axes["a"][:-1], b=axes["b"])
    import zarr

    DONE.clear()
    seen = []
    kept = int(np.asarray(zarr.open_group(str(store), mode="r")["_done"][...]).sum())
    assert 1 <= kept < 14
    resumed = sweep(fragile, chunk=27, out=store, resume=True, progress=lambda done, total: seen.append(done), **axes)
    assert len(DONE) == 14 - kept  # only what was missing: the blocks done before the interruption are kept
    assert seen[0] == kept and seen[-1] == 14
    np.testing.assert_array_equal(resumed["f"].values, whole["f"].values)
    np.testing.assert_array_equal(resumed["status"].values, whole["status"].values)


def touchy(a):
    if np.any(a > 0.8):
        raise ValueError("no convergence above 0.8")
    return {"y": a**2, "n": np.full(a.shape, 3)}


def test_a_member_that_raises_is_its_own_status(tmp_path):
    a = np.linspace(0.0, 1.0, 11)
    ds = sweep(touchy, a=a, chunk=4, out=tmp_path / "t.zarr")
    bad = a > 0.8
    np.testing.assert_array_equal(ds["status"].values, bad.astype(np.int8))
    assert np.isnan(ds["y"].values[bad]).all() and np.array_equal(ds["y"].values[~bad], a[~bad] ** 2)
    assert (ds["n"].values[bad] == -1).all()
    failures = json.loads(ds.attrs["failures"])
    assert len(failures) == 2 and all("no convergence" in v for v in failures.values())


def test_a_study_without_a_store_is_the_study_with_one(tmp_path):
    """Without `out` the blocks fill arrays in memory: the same Dataset (data, units, status, failures, provenance)
    as the store's, to the last bit."""
    a, b = np.linspace(0.0, 1.0, 11), np.array([1.0, 2.0])
    kw = dict(a=a, chunk=4, units={"y": "m", "a": "rad"})
    stored, memory = sweep(touchy, out=tmp_path / "t.zarr", **kw), sweep(touchy, **kw)
    assert memory.identical(stored)
    assert json.loads(memory.attrs["failures"]) == json.loads(stored.attrs["failures"]) != {}
    assert memory["status"].attrs["flag_meanings"] == "not_computed done study_raised"
    grid = sweep(trig, a=a, b=b, chunk=3, fixed={"scale": 2.0}, out=tmp_path / "g.zarr")
    assert sweep(trig, a=a, b=b, chunk=3, fixed={"scale": 2.0}).identical(grid)
    samples = dict(I1=("normal", 2.6, 0.05), I2=("uniform", 1.9, 2.1))
    drawn = monte_carlo(spin_up, 9, seed=5, chunk=4, out=tmp_path / "m.zarr", **samples)
    assert monte_carlo(spin_up, 9, seed=5, chunk=4, **samples).identical(drawn)


def test_bad_studies_are_refused_before_the_work():
    with pytest.raises(InputError, match="at least one axis"):
        sweep(trig)
    with pytest.raises(InputError, match="1-D"):
        sweep(trig, a=np.ones((2, 2)), b=[1.0])
    with pytest.raises(InputError, match="distribution"):
        monte_carlo(trig, 10, seed=1, a=("gaussian", 0, 1), b=("uniform", 0, 1))
    with pytest.raises(InputError, match="low < high"):
        monte_carlo(trig, 10, seed=1, a=("uniform", 1, 0), b=("uniform", 0, 1))
    with pytest.raises(InputError, match="seed"):
        monte_carlo(trig, 10, seed=-1, a=("uniform", 0, 1), b=("uniform", 0, 1))
    with pytest.raises(InputError, match="max_members"):
        sweep(trig, a=np.arange(1000.0), b=np.arange(1000.0), max_members=10**5)
    with pytest.raises(InputError, match="also swept"):
        sweep(trig, a=[0.0, 1.0], b=[1.0], fixed={"a": 1.0})
    with pytest.raises(InputError, match="first axis the 2 members|first axis the 1 members"):
        sweep(lambda a: {"y": np.zeros(3)}, a=[0.0, 1.0])
    with pytest.raises(InputError, match="resume.*give `out`"):
        sweep(trig, a=[0.0], b=[1.0], resume=True)


# --------------------------------------------------------------------------------------------------
# on a cluster: real worker processes on 127.0.0.1, one of them killed in the middle of the study
# --------------------------------------------------------------------------------------------------
def slow(a, b):
    time.sleep(0.3)
    return {"f": np.exp(-a) * np.sin(b), "g": a * b}


def test_a_cluster_that_loses_a_worker_finishes_the_study(tmp_path):
    distributed = pytest.importorskip("distributed")
    import cloudpickle

    cloudpickle.register_pickle_by_value(sys.modules[__name__])  # the workers cannot import this test module
    axes = dict(a=np.linspace(0.0, 2.0, 24), b=np.linspace(0.0, 1.0, 5))
    serial = sweep(slow, chunk=10, **axes)  # 24 blocks of 2 x 5
    store = tmp_path / "cluster.zarr"
    with (
        distributed.LocalCluster(
            n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1", dashboard_address=None
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        outcome = {}

        def run():
            try:
                outcome["ds"] = sweep(slow, chunk=10, out=store, scheduler=cluster.scheduler_address, **axes)
            except BaseException as exc:  # noqa: BLE001 - reported by the assertion below
                outcome["error"] = exc

        worker = threading.Thread(target=run)
        worker.start()
        import zarr

        deadline = time.time() + 60
        while time.time() < deadline:
            try:
                if int(np.asarray(zarr.open_group(str(store), mode="r")["_done"][...]).sum()) >= 3:
                    break
            except Exception:  # noqa: BLE001 - the store is being created
                pass
            time.sleep(0.05)
        pids = client.run(os.getpid)
        victim = sorted(pids)[0]
        os.kill(pids[victim], signal.SIGKILL)  # mid-run: its block is lost and rescheduled
        worker.join(120)
        assert not worker.is_alive() and "error" not in outcome, outcome.get("error")
    ds = outcome["ds"]
    np.testing.assert_array_equal(ds["f"].values, serial["f"].values)
    np.testing.assert_array_equal(ds["g"].values, serial["g"].values)
    assert (ds["status"].values == 0).all()
