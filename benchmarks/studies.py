"""Studies over many parameter values (geomech.sweep): a stability map and a snakeboard gait ensemble, on this
machine's cores (dask's threaded scheduler) and on a dask.distributed LocalCluster of 1 and 2 worker processes.

    PYTHONPATH=src python benchmarks/studies.py           # a 100 x 100 map and 100,000 gaits, about 10 minutes
    PYTHONPATH=src python benchmarks/studies.py --quick   # a 30 x 30 map and 10,000 gaits
    PYTHONPATH=src python benchmarks/studies.py --scale   # a 200 x 200 map; 4 worker processes; peak memory

Not part of the test suite. The problems (issue 18, item 5; issue 16, item 4):

- ``stability_map``: one rotor on axis 3 of the body diag(3, 2, 1) under phi(v) = k v + a v^3 with p = 0.1 (no
  closed-form boundary), G = 1, over k in [0.05, 0.95] and a in [-0.9, 0.9]: at each point every relative
  equilibrium is found (continued along a block's row, searched afresh where Poincare-Hopf fails) and the one
  nearest to the intermediate-axis spin is assessed three ways. One task is one row. The map runs point by point
  in Python (``backend="python"``, the path of a family without a formula); compiled it takes half a second
  (``benchmarks/stability_map.py``).
- ``gait_ensemble``: the snakeboard (m = 1, r = 0.5, J = 0.18, J0 = 0.05, J1 = 0.01) from rest over five periods
  of psi = a sin(2 pi t), phi = b sin(2 pi t + c), a in [0.5, 1.5], b in [0.2, 0.8], c in [0, 2 pi): the net
  displacement and momentum change of each gait (``GaitSweep``, BKMM compiled, rtol 1e-10); one task is a
  block of 2,500 gaits, one compiled batch.

Each study runs three ways, with a fresh Zarr store each time: the default (dask's threaded scheduler over every
core, numba's loops one thread per task), and a LocalCluster of 1 worker process with 2 threads, and of 2 worker
processes with 1 thread each (each process with its own memory limit). The compiled kernels are on disk before the
timed runs (a small warm-up study in each configuration). Every run's data are checked equal, to the last bit, to
the first's. Writes ``results/studies.json`` and ``results/studies.md``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import shutil
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

import geomech as gm
from geomech.analysis import GaitSweep, stability_map
from geomech.systems.nonholonomic_examples import snakeboard

HERE = Path(__file__).resolve().parent


def control_family() -> Any:
    body = gm.RotorBody.one_rotor(3.0, 2.0, 1.0)
    control = gm.StructurePreservingControl.one_rotor(
        body, "k*v + a*v**3", p=0.1, parameters={"k": 0.5, "a": 0.0}, probe_radius=1.0
    )
    return control.family()


def run_map(n: int, where: Any, store: Path) -> tuple[float, Any]:
    family = control_family()
    t = time.perf_counter()
    ds = stability_map(
        family,
        ("k", np.linspace(0.05, 0.95, n)),
        ("a", np.linspace(-0.9, 0.9, n)),
        out=store,
        scheduler=where,
        max_points=10**7,
        backend="python",  # point by point in Python: work for a cluster (compiled: benchmarks/stability_map.py)
    ).load()
    return time.perf_counter() - t, ds


def run_gaits(shape: tuple[int, int, int], where: Any, store: Path) -> tuple[float, Any]:
    s = snakeboard(m=1.0, r=0.5, J=0.18, J0=0.05, J1=0.01)
    study = GaitSweep(s, {"psi": "a*sin(2*pi*t)", "phi": "b*sin(2*pi*t + c)"}, period=1.0, periods=5)
    t = time.perf_counter()
    ds = study.run(
        a=np.linspace(0.5, 1.5, shape[0]),
        b=np.linspace(0.2, 0.8, shape[1]),
        c=np.linspace(0, 2 * np.pi, shape[2], endpoint=False),
        out=store,
        scheduler=where,
        chunk=2500,
    ).load()
    return time.perf_counter() - t, ds


def peak_rss_mib() -> float:
    """This process's peak resident memory (MiB); run in a worker by ``client.run``."""
    import resource

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def local_cluster(workers: int, memory_limit: str) -> tuple[Any, Any]:
    import distributed

    cluster = distributed.LocalCluster(
        n_workers=workers,
        processes=True,
        threads_per_worker=1,
        host="127.0.0.1",
        dashboard_address=None,
        memory_limit=memory_limit,
    )
    return cluster, distributed.Client(cluster)


def scale(n_map: int, workers: int, gaits: tuple[int, int, int]) -> int:
    """The larger runs of issue 18, item 5: an ``n_map`` x ``n_map`` stability map on 2 worker processes (the
    fastest configuration of the map above), and both studies on a cluster of ``workers`` worker processes with
    1 GiB each (more processes than cores: the same code a cluster of machines would run), with every worker's
    peak memory. Writes ``results/studies_scale.json`` and ``results/studies_scale.md``."""
    scratch = Path(tempfile.mkdtemp(prefix="geomech-bench-"))
    rows: list[dict[str, Any]] = []
    plans = [
        ("2 processes x 1 thread", 2, "4GiB", [("stability_map", n_map)]),
        (f"{workers} processes x 1 thread, 1 GiB each", workers, "1GiB", [("stability_map", 100), ("gaits", 0)]),
    ]
    try:
        for label, n_workers, limit, studies in plans:
            cluster, client = local_cluster(n_workers, limit)
            try:
                run_map(4, client, scratch / f"warm-map-{n_workers}.zarr")
                run_gaits((2, 2, 2), client, scratch / f"warm-gait-{n_workers}.zarr")
                for name, size in studies:
                    store = scratch / f"{name}-{n_workers}-{size}.zarr"
                    if name == "stability_map":
                        wall, ds = run_map(size, client, store)
                        members, shape = size * size, f"{size} x {size}"
                    else:
                        wall, ds = run_gaits(gaits, client, store)
                        members, shape = int(np.prod(gaits)), " x ".join(map(str, gaits))
                    store_mib = sum(f.stat().st_size for f in store.rglob("*") if f.is_file()) / 2**20
                    peaks = sorted(client.run(peak_rss_mib).values())
                    rows.append(
                        dict(
                            study=name,
                            grid=shape,
                            members=members,
                            where=label,
                            wall_s=wall,
                            per_member_us=wall / members * 1e6,
                            status_nonzero=int((ds["status"].values != 0).sum()),
                            worker_peak_rss_mib=peaks,
                            store_mib=store_mib,
                        )
                    )
                    print(rows[-1], flush=True)
            finally:
                client.close()
                cluster.close()
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    out = dict(
        machine=f"{platform.machine()} {platform.processor()}, {platform.python_version()}, {os.cpu_count()} CPUs",
        command=f"PYTHONPATH=src python benchmarks/studies.py --scale (map {n_map} x {n_map}, {workers} workers)",
        controller_peak_rss_mib=peak_rss_mib(),
        rows=rows,
    )
    results = HERE / "results"
    results.mkdir(exist_ok=True)
    (results / "studies_scale.json").write_text(json.dumps(out, indent=1) + "\n")
    lines = [
        "| study | grid | where | wall time (s) | per member (us) | workers' peak memory (MiB) | store (MiB) |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        peaks = ", ".join(f"{x:.0f}" for x in r["worker_peak_rss_mib"])
        lines.append(
            f"| {r['study']} | {r['grid']} | {r['where']} | {r['wall_s']:.1f} | {r['per_member_us']:.0f} | {peaks} | "
            f"{r['store_mib']:.1f} |"
        )
    table = "\n".join(lines) + f"\n\ncontroller peak memory: {out['controller_peak_rss_mib']:.0f} MiB\n"
    (results / "studies_scale.md").write_text(table)
    print(table)
    return 0


def same(a: Any, b: Any) -> bool:
    return all(np.array_equal(a[v].values, b[v].values, equal_nan=True) for v in a.data_vars)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="a 30 x 30 map and 10,000 gaits")
    ap.add_argument("--scale", action="store_true", help="a 200 x 200 map; 4 worker processes; peak memory")
    args = ap.parse_args(argv)
    try:
        import distributed
    except ImportError:
        print("studies.py: dask.distributed is not installed", file=sys.stderr)
        return 2
    if args.scale:
        return scale(40 if args.quick else 200, 4, (10, 10, 100) if args.quick else (100, 10, 100))
    n_map = 30 if args.quick else 100
    gaits = (10, 10, 100) if args.quick else (100, 10, 100)
    scratch = Path(tempfile.mkdtemp(prefix="geomech-bench-"))
    rows: list[dict[str, Any]] = []
    reference: dict[str, Any] = {}
    configurations = [
        ("threads", None, {}),
        ("1 process x 2 threads", 1, {"threads_per_worker": 2}),
        ("2 processes x 1 thread", 2, {"threads_per_worker": 1}),
    ]
    try:
        for label, workers, options in configurations:
            cluster = client = None
            where: Any = None
            if workers is not None:
                cluster = distributed.LocalCluster(
                    n_workers=workers,
                    processes=True,
                    host="127.0.0.1",
                    dashboard_address=None,
                    memory_limit="4GiB",
                    **options,
                )
                client = distributed.Client(cluster)
                where = client
            try:
                # warm-up: each process loads the compiled kernels (numba's disk cache) once
                run_map(4, where, scratch / f"warm-map-{label}.zarr")
                run_gaits((2, 2, 2), where, scratch / f"warm-gait-{label}.zarr")
                for name, runner, size in (
                    ("stability_map", lambda w, p: run_map(n_map, w, p), n_map * n_map),
                    ("gait_ensemble", lambda w, p: run_gaits(gaits, w, p), int(np.prod(gaits))),
                ):
                    wall, ds = runner(where, scratch / f"{name}-{label}.zarr")
                    if name not in reference:
                        reference[name] = ds
                    rows.append(
                        dict(
                            study=name,
                            members=size,
                            where=label,
                            wall_s=wall,
                            per_member_us=wall / size * 1e6,
                            identical_to_first=same(ds, reference[name]),
                            status_nonzero=int((ds["status"].values != 0).sum()),
                        )
                    )
                    print(rows[-1], flush=True)
            finally:
                if client is not None:
                    client.close()
                if cluster is not None:
                    cluster.close()
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    verdicts = {
        int(k): int(v) for k, v in zip(*np.unique(reference["stability_map"]["verdict"].values, return_counts=True))
    }
    out = dict(
        machine=f"{platform.machine()} {platform.processor()}, {platform.python_version()}, {os.cpu_count()} CPUs",
        versions=json.loads(reference["gait_ensemble"].attrs["versions"]),
        command="PYTHONPATH=src python benchmarks/studies.py" + (" --quick" if args.quick else ""),
        map_size=[n_map, n_map],
        gait_grid=list(gaits),
        map_verdict_counts=verdicts,
        rows=rows,
    )
    results = HERE / "results"
    results.mkdir(exist_ok=True)
    (results / "studies.json").write_text(json.dumps(out, indent=1) + "\n")
    lines = [
        "| study | members | where | wall time (s) | per member (us) | data identical to the first run |",
        "|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['study']} | {r['members']} | {r['where']} | {r['wall_s']:.2f} | {r['per_member_us']:.1f} | "
            f"{'yes' if r['identical_to_first'] else 'NO'} |"
        )
    table = "\n".join(lines) + "\n"
    (results / "studies.md").write_text(table)
    print(table)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
