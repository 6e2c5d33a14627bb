"""Campaign throughput and memory: N synthetic blocks on the process pool and on a 2-worker Dask cluster.

    python benchmarks/campaign_bench.py --blocks 60            # 60 blocks of 20-300 ha, 2 workers
    python benchmarks/campaign_bench.py --blocks 1000 --workers 2

The blocks: rectangles, convex and concave (star) polygons of 20-300 ha (uniform), near 49.4 N
15 E; a tenth of them hold an exclusion zone (the template's zone file holds one zone inside each of
those blocks). Template: Sony a6000 16 mm, 2.5 cm GSD, 75/60 % overlap, copter, the default outputs
(manifest and the pilots' files).

Each measurement runs in a fresh process:
- single: every block planned one after the other in one process (`plan_block`), the CPU time of
  each (time.process_time); the ideal for W workers is their sum / W;
- pool, dask: the campaign on a local process pool / a LocalCluster (W single-threaded worker
  processes; its start is timed apart), wall time from the first block handed out to the last
  result, the peak RSS of the workers (the pool's children; each Dask worker's own) and of the
  driver (the process running the campaign: flat in the number of blocks when it holds no plan);
- largest: the largest block planned alone in a fresh process: its peak RSS.
The driver's CPU time while the campaign runs is printed too: on 2 cores it competes with the
workers (a LocalCluster's scheduler runs in the driver's process).
Prints the ratios: wall / (sum of single-block CPU / W) (goal 1.2, issue 38) and worker peak RSS /
the largest block's (goal 1.5).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import shapely

LAT0, LON0 = 49.4, 15.0
K_LON, K_LAT = 111_320.0 * math.cos(math.radians(LAT0)), 111_320.0


def _lonlat(g: shapely.Geometry) -> shapely.Geometry:
    return shapely.transform(g, lambda a: np.column_stack([LON0 + a[:, 0] / K_LON, LAT0 + a[:, 1] / K_LAT]))


def make_inputs(folder: Path, n: int, seed: int) -> tuple[Path, Path]:
    """The blocks file and the template (with its zone file)."""
    rng = np.random.default_rng(seed)
    feats, zones = [], []
    side = math.ceil(math.sqrt(n))
    for i in range(n):
        target = rng.uniform(20, 300) * 1e4
        kind = ("rectangle", "convex", "concave")[i % 3]
        if kind == "rectangle":
            g = shapely.box(0, 0, rng.uniform(1, 3), 1)
        elif kind == "convex":
            g = shapely.convex_hull(shapely.MultiPoint(rng.uniform(-1, 1, (12, 2))))
        else:
            ang = np.sort(rng.uniform(0, 2 * np.pi, 9))
            rad = rng.uniform(0.4, 1.0, 9)
            g = shapely.Polygon(np.column_stack([rad * np.cos(ang), rad * np.sin(ang)]))
            g = g if g.is_valid else shapely.convex_hull(g)
        g = shapely.affinity.scale(g, math.sqrt(target / g.area), math.sqrt(target / g.area), origin="centroid")
        c = g.centroid
        g = shapely.affinity.translate(g, (i % side) * 2500 - c.x, (i // side) * 2500 - c.y)
        if i % 10 == 5:  # a tenth with a zone: a 60 m square around a point inside the block
            p = g.representative_point()
            zones.append(_lonlat(shapely.box(p.x - 30, p.y - 30, p.x + 30, p.y + 30)))
        feats.append({"type": "Feature", "properties": {"name": f"s{i:04d}"}, "geometry": shapely.geometry.mapping(_lonlat(g))})
    (folder / "blocks.geojson").write_text(json.dumps({"type": "FeatureCollection", "features": feats}))
    (folder / "zones.geojson").write_text(json.dumps({"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {}, "geometry": shapely.geometry.mapping(z)} for z in zones]}))
    (folder / "template.toml").write_text(
        '[mission]\nname = "bench"\n[area]\nexclusions = ["zones.geojson"]\n[camera]\nmodel = "sony-a6000-16mm"\n'
        '[targets]\ngsd_cm = 2.5\nforward_overlap = 0.75\nside_overlap = 0.6\n[vehicle]\ntype = "copter"\n')
    return folder / "blocks.geojson", folder / "template.toml"


def _jobs(folder: Path) -> list:
    from aerosurvey.campaign.blocks import read_blocks
    from aerosurvey.campaign.job import DEFAULT_OUTPUTS, make_jobs

    crs, blocks = read_blocks(folder / "blocks.geojson")
    return make_jobs(blocks, crs, folder / "template.toml", DEFAULT_OUTPUTS)


def _cpu_s(who: int) -> float:
    ru = resource.getrusage(who)
    return ru.ru_utime + ru.ru_stime


def _maxrss_mb(who: int) -> float:
    return resource.getrusage(who).ru_maxrss / 1024


def mode_single(folder: Path) -> dict:
    import aerosurvey.inputs
    import aerosurvey.outputs  # noqa: F401  (imported before the clock starts, as the pool's workers have them)
    from aerosurvey.campaign.job import plan_block

    out = Path(tempfile.mkdtemp(dir=folder))
    cpu, status = [], []
    for job in _jobs(folder):
        t = time.process_time()
        status.append(plan_block(job, str(out)).status)
        cpu.append(time.process_time() - t)
    return {"cpu_s": cpu, "status": status}


def mode_largest(folder: Path, index: int) -> dict:
    from aerosurvey.campaign.job import plan_block

    out = Path(tempfile.mkdtemp(dir=folder))
    plan_block(_jobs(folder)[index], str(out))
    return {"maxrss_mb": _maxrss_mb(resource.RUSAGE_SELF)}


def mode_pool(folder: Path, workers: int) -> dict:
    from aerosurvey.campaign.run import pool_results, run_campaign

    out = Path(tempfile.mkdtemp(dir=folder))
    jobs = _jobs(folder)
    t, c = time.perf_counter(), _cpu_s(resource.RUSAGE_SELF)
    results, tally = run_campaign(jobs, out, pool_results(workers))
    wall, driver_cpu = time.perf_counter() - t, _cpu_s(resource.RUSAGE_SELF) - c
    ru = resource.getrusage(resource.RUSAGE_CHILDREN)
    return {"wall_s": wall, "done": tally.done, "failed": tally.failed, "worker_maxrss_mb": ru.ru_maxrss / 1024,
            "worker_cpu_s": ru.ru_utime + ru.ru_stime, "driver_cpu_s": driver_cpu, "driver_maxrss_mb": _maxrss_mb(resource.RUSAGE_SELF)}


def mode_dask(folder: Path, workers: int) -> dict:
    import logging

    import dask
    from distributed import Client, LocalCluster

    from aerosurvey.campaign.run import LOCAL_CLUSTER_CONFIG, dask_results, run_campaign

    logging.getLogger("distributed").setLevel(logging.WARNING)
    out = Path(tempfile.mkdtemp(dir=folder))
    jobs = _jobs(folder)
    t0 = time.perf_counter()
    with dask.config.set(LOCAL_CLUSTER_CONFIG), \
            LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=":0") as cluster, \
            Client(cluster) as client:
        # the workers' imports, as a pool's fork has them; their CPU time so far
        client.run(lambda: [__import__(m) for m in ("aerosurvey.inputs", "aerosurvey.outputs", "aerosurvey.campaign.job")])
        cpu_before = client.run(lambda: (lambda r: r.ru_utime + r.ru_stime)(resource.getrusage(resource.RUSAGE_SELF)))
        t1, c1 = time.perf_counter(), _cpu_s(resource.RUSAGE_SELF)
        results, tally = run_campaign(jobs, out, dask_results(client))
        wall, driver_cpu = time.perf_counter() - t1, _cpu_s(resource.RUSAGE_SELF) - c1
        cpu0 = sum(cpu_before.values())
        usage = client.run(lambda: [*(lambda r: (r.ru_maxrss / 1024, r.ru_utime + r.ru_stime))(
            resource.getrusage(resource.RUSAGE_SELF))])
    return {"wall_s": wall, "start_s": t1 - t0, "done": tally.done, "failed": tally.failed,
            "worker_maxrss_mb": max(u[0] for u in usage.values()), "worker_cpu_s": sum(u[1] for u in usage.values()) - cpu0,
            "driver_cpu_s": driver_cpu, "driver_maxrss_mb": _maxrss_mb(resource.RUSAGE_SELF)}


def register_figures(n: int, folder: Path) -> str:
    """register.gpkg of `n` blocks (squares) with two events each: its size, the time to write it, and the
    time of `campaign status` (the whole command, Python's start included; and reading the register alone)."""
    from aerosurvey.campaign.register import BlockRow, Event, read_register, write_register

    out = folder / f"register-{n}"
    out.mkdir()
    rows = [BlockRow(f"s{i:05d}", f"{i:020x}", f"s{i:05d}.{i:020x}", "planned",
                     shapely.to_wkb(_lonlat(shapely.box(i % 100 * 2500, i // 100 * 2500, i % 100 * 2500 + 1000, i // 100 * 2500 + 1000))),
                     120.0, 1500, 45.0, 30.0, 2, 2.5, 14, 13, "cz-gsd", "") for i in range(n)]
    events = [Event(r.name, r.key, e, "2026-11-28T12:00:00Z", "") for r in rows for e in ("planned", "flown")]
    t = time.perf_counter()
    write_register(out, rows, events)
    write_s = time.perf_counter() - t
    t = time.perf_counter()
    read_register(out)
    read_s = time.perf_counter() - t
    t = time.perf_counter()
    subprocess.run([sys.executable, "-c", "from aerosurvey.cli import main; main()", "campaign", "status", str(out)],
                   capture_output=True, check=True)
    status_s = time.perf_counter() - t
    size = (out / "register.gpkg").stat().st_size / 1e6
    return (f"register of {n} blocks, {2 * n} events: {size:.1f} MB, written in {write_s:.2f} s; `campaign status` "
            f"{status_s:.2f} s (reading the register {read_s:.2f} s)")


def _child(mode: str, folder: Path, *more: str) -> dict:
    res = subprocess.run([sys.executable, __file__, "--mode", mode, "--folder", str(folder), *more],
                         capture_output=True, text=True, check=False)
    if res.returncode != 0:
        raise SystemExit(f"{mode} failed:\n{res.stderr}")
    return json.loads(res.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--blocks", type=int, default=60)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--seed", type=int, default=38)
    ap.add_argument("--mode", default=None, help=argparse.SUPPRESS)
    ap.add_argument("--folder", type=Path, default=None, help=argparse.SUPPRESS)
    ap.add_argument("--index", type=int, default=0, help=argparse.SUPPRESS)
    ap.add_argument("--register", type=int, nargs="*", default=[1000, 10000], help="register sizes to measure")
    a = ap.parse_args()
    if a.mode is not None:
        fn = {"single": lambda: mode_single(a.folder), "largest": lambda: mode_largest(a.folder, a.index),
              "pool": lambda: mode_pool(a.folder, a.workers), "dask": lambda: mode_dask(a.folder, a.workers)}[a.mode]
        print(json.dumps(fn()))
        return
    with tempfile.TemporaryDirectory(prefix="campaign-bench-") as tmp:
        folder = Path(tmp)
        make_inputs(folder, a.blocks, a.seed)
        feats = json.loads((folder / "blocks.geojson").read_text())["features"]
        areas = [shapely.geometry.shape(f["geometry"]).area * K_LON * K_LAT / 1e4 for f in feats]
        single = _child("single", folder)
        cpu = np.array(single["cpu_s"])
        largest = int(np.argmax(areas))
        ideal = cpu.sum() / a.workers
        print(f"{a.blocks} blocks, {min(areas):.0f}-{max(areas):.0f} ha ({sum(areas):.0f} ha), {a.blocks // 10} with a zone; "
              f"{a.workers} workers; {os.cpu_count()} cores; load average {os.getloadavg()[0]:.1f} at the start")
        print(f"single-block CPU: sum {cpu.sum():.1f} s, median {np.median(cpu):.2f} s, max {cpu.max():.2f} s; "
              f"statuses {dict(zip(*np.unique(single['status'], return_counts=True)))}; ideal wall (sum / {a.workers}) {ideal:.1f} s")
        big = _child("largest", folder, "--index", str(largest))
        print(f"largest block ({areas[largest]:.0f} ha) alone: peak RSS {big['maxrss_mb']:.0f} MB")
        for n in a.register:
            print(register_figures(n, folder))
        for mode in ("pool", "dask"):
            print(f"  load average {os.getloadavg()[0]:.1f}")
            r = _child(mode, folder, "--workers", str(a.workers))
            start = f", cluster start {r['start_s']:.1f} s apart" if "start_s" in r else ""
            print(f"{mode}: wall {r['wall_s']:.1f} s = {r['wall_s'] / ideal:.2f} x ideal{start}; workers' CPU "
                  f"{r['worker_cpu_s']:.1f} s = {r['worker_cpu_s'] / cpu.sum():.2f} x the single-block sum; the driver's CPU "
                  f"{r['driver_cpu_s']:.1f} s{' (the scheduler runs in it)' if mode == 'dask' else ''}; {r['done']} done, "
                  f"{r['failed']} failed; worker peak RSS {r['worker_maxrss_mb']:.0f} MB = "
                  f"{r['worker_maxrss_mb'] / big['maxrss_mb']:.2f} x the largest block's; driver peak RSS "
                  f"{r['driver_maxrss_mb']:.0f} MB")


if __name__ == "__main__":
    main()
