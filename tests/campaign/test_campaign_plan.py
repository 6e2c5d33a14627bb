"""`aerosurvey campaign plan`: the same campaign whichever executor ran it, however often it was
interrupted (the driver killed, a worker killed) and run again; the blocks' overrides reach their plans."""

from __future__ import annotations

import json
import multiprocessing
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import campaigncase as cc
import pytest
from click.testing import CliRunner

from aerosurvey.cli import main

N_BLOCKS = 20
OVERRIDES = {1: {"gsd_cm": 2.0}, 2: {"heading": 30.0}, 3: {"launch_lon": 15.0045, "launch_lat": 49.4004},
             4: {"height_m": 60.0}}


def campaign_plan(blocks: Path, template: Path, out: Path, *more: str, code: int = 0) -> str:
    res = CliRunner().invoke(main, ["campaign", "plan", str(blocks), "-o", str(out), "--spec", str(template), *more])
    assert res.exit_code == code, res.output + repr(res.exception)
    return res.output


@pytest.fixture(scope="module")
def inputs(tmp_path_factory) -> tuple[Path, Path]:
    folder = tmp_path_factory.mktemp("inputs")
    return cc.write_blocks(folder / "blocks.geojson", N_BLOCKS, props=OVERRIDES), cc.write_template(folder)


@pytest.fixture(scope="module")
def reference(inputs, tmp_path_factory) -> Path:
    """The campaign planned in one uninterrupted run on the process pool."""
    out = tmp_path_factory.mktemp("reference") / "campaign"
    campaign_plan(*inputs, out, "--workers", "2")
    return out


def test_every_block_planned_once_with_its_overrides(reference):
    folders = cc.block_folders(reference)
    assert sorted(folders) == [f"t{i:02d}" for i in range(N_BLOCKS)]
    manifests = {n: json.loads((f / "manifest.json").read_text()) for n, f in folders.items()}
    for name, folder in folders.items():
        assert sorted(p.name for p in folder.iterdir()) == ["block.json", "manifest.json", "mission.plan", "mission.waypoints",
                                                             "outline.geojson"]
        assert manifests[name]["mission"]["name"] == name
    assert manifests["t00"]["targets"]["gsd_cm"] == pytest.approx(2.5)
    assert manifests["t01"]["targets"]["gsd_cm"] == pytest.approx(2.0)
    assert manifests["t02"]["derived"]["heading_deg"] == pytest.approx(30.0, abs=0.01)
    assert manifests["t04"]["derived"]["height_agl_m"] == pytest.approx(60.0)
    # the launch point: the mission's home is there (the .waypoints' first row: lat, lon in columns 8, 9)
    home = (folders["t03"] / "mission.waypoints").read_text().splitlines()[1].split("\t")
    assert float(home[9]) == pytest.approx(15.0045) and float(home[8]) == pytest.approx(49.4004)
    rows, events = cc.register(reference)
    assert [r["name"] for r in rows] == [f"t{i:02d}" for i in range(N_BLOCKS)]
    assert {r["status"] for r in rows} == {"planned"}
    assert all(r["photos"] == json.loads((folders[r["name"]] / "block.json").read_text())["photos"] > 0 for r in rows)
    assert sorted((e["block"], e["event"]) for e in events) == [(f"t{i:02d}", "planned") for i in range(N_BLOCKS)]


def test_rerun_plans_nothing_and_adds_no_event(inputs, reference, tmp_path):
    out = tmp_path / "campaign"
    campaign_plan(*inputs, out, "--workers", "2")
    stamps = {p: p.stat().st_mtime_ns for p in out.glob("blocks/*/block.json")}
    text = campaign_plan(*inputs, out, "--workers", "2")
    assert f"{N_BLOCKS} done ({N_BLOCKS} earlier), 0 failed, 0 remaining" in text
    assert {p: p.stat().st_mtime_ns for p in out.glob("blocks/*/block.json")} == stamps
    cc.same_campaign(out, reference)


def test_dask_local_cluster_gives_the_same_campaign(inputs, reference, tmp_path):
    out = tmp_path / "campaign"
    campaign_plan(*inputs, out, "--workers", "2", "--dask", "local")
    cc.same_campaign(out, reference)


def test_outputs_choose_the_files(inputs, tmp_path):
    blocks = cc.write_blocks(tmp_path / "two.geojson", 2)
    out = tmp_path / "campaign"
    campaign_plan(blocks, inputs[1], out, "--outputs", "pilot,preview,gpkg", "--workers", "1")
    for folder in cc.block_folders(out).values():
        assert sorted(p.name for p in folder.iterdir()) == ["block.json", "mission.plan", "mission.waypoints", "outline.geojson",
                                                           "plan.gpkg", "preview.svg"]
    res = CliRunner().invoke(main, ["campaign", "plan", str(blocks), "-o", str(tmp_path / "x"), "--spec", str(inputs[1]),
                                    "--outputs", "pilot,photos"])
    assert res.exit_code == 2 and "--outputs = 'pilot,photos' is not allowed" in res.output


def test_failed_block_is_recorded_and_the_rest_planned(inputs, tmp_path):
    # 10 cm GSD needs ~490 m above the ground: above the 120 m cap
    blocks = cc.write_blocks(tmp_path / "blocks.geojson", 3, props={1: {"gsd_cm": 10.0}})
    out = tmp_path / "campaign"
    text = campaign_plan(blocks, inputs[1], out, "--workers", "1", code=1)
    assert "1 block(s) failed (t01)" in text
    assert sorted(cc.block_folders(out)) == ["t00", "t02"]
    rows, events = cc.register(out)
    failed = [r for r in rows if r["status"] == "failed"]
    assert [r["name"] for r in failed] == ["t01"] and "above the cap vehicle.max_height_agl_m" in failed[0]["message"]
    assert [e["event"] for e in events if e["block"] == "t01"] == ["failed"]
    res = CliRunner().invoke(main, ["campaign", "status", str(out)])
    assert res.exit_code == 0
    assert "3 blocks, 3 events: 1 failed, 2 planned" in res.output
    assert "t01: failed (targets: GSD 10.00 cm" in res.output and "run `campaign plan` again" in res.output
    # a second attempt fails the same way: one more failed event, still no folder
    campaign_plan(blocks, inputs[1], out, "--workers", "1", code=1)
    assert [e["event"] for e in cc.register(out)[1] if e["block"] == "t01"] == ["failed", "failed"]


@pytest.mark.parametrize("executor", [(), ("--dask", "local")], ids=["pool", "dask"])
def test_driver_killed_mid_run_then_rerun(inputs, reference, tmp_path, executor):
    out = tmp_path / "campaign"
    cmd = [sys.executable, "-c", "from aerosurvey.cli import main; main()", "campaign", "plan", str(inputs[0]), "-o", str(out),
           "--spec", str(inputs[1]), "--workers", "1", *executor]
    proc = subprocess.Popen(cmd, start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        deadline = time.monotonic() + 120
        done: list[Path] = []
        while time.monotonic() < deadline and proc.poll() is None:
            done = [p for p in (out / "blocks").glob("t*") if p.is_dir()] if (out / "blocks").is_dir() else []
            if len(done) >= 2:
                break
            time.sleep(0.005)
        assert proc.poll() is None, "the campaign ended before it could be killed: " + proc.stderr.read().decode()
        os.killpg(proc.pid, signal.SIGKILL)  # the driver and its workers (the pool's, or the LocalCluster's)
        proc.wait(10)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    assert not (out / "register.gpkg").exists()
    assert 2 <= len([p for p in (out / "blocks").glob("t*")]) < N_BLOCKS
    campaign_plan(*inputs, out, "--workers", "2")
    cc.same_campaign(out, reference)


def _kill_one_worker_when(done_at: int, pids) -> object:
    """A progress report that kills one worker process (SIGKILL) once `done_at` blocks are done."""
    state = {"killed": False, "calls": 0}

    def report(stage: str, done: float) -> None:
        state["calls"] += 1
        if not state["killed"] and state["calls"] > done_at:
            os.kill(pids()[0], signal.SIGKILL)
            state["killed"] = True

    report.state = state  # type: ignore[attr-defined]
    return report


def _jobs(inputs):
    from aerosurvey.campaign.blocks import read_blocks
    from aerosurvey.campaign.job import DEFAULT_OUTPUTS, make_jobs

    crs, blocks = read_blocks(inputs[0])
    return make_jobs(blocks, crs, inputs[1], DEFAULT_OUTPUTS)


def test_pool_worker_killed_then_rerun(inputs, reference, tmp_path):
    from aerosurvey.campaign.run import pool_results, run_campaign

    out = tmp_path / "campaign"
    report = _kill_one_worker_when(3, lambda: [p.pid for p in multiprocessing.active_children()])
    results, tally = run_campaign(_jobs(inputs), out, pool_results(2), report)
    assert report.state["killed"]
    failed = [r for r in results if r.status == "failed"]
    assert failed and all("worker process running it died" in r.message for r in failed)
    assert tally.done + tally.failed == N_BLOCKS  # a new pool planned the rest
    campaign_plan(*inputs, out, "--workers", "2")
    cc.same_campaign(out, reference)


@pytest.mark.parametrize("allowed_failures", [0, 3])
def test_dask_worker_killed_then_rerun(inputs, reference, tmp_path, allowed_failures):
    """With allowed-failures 0 the blocks on the killed worker come back failed (KilledWorker) and the
    rerun plans them; with Dask's default 3 the scheduler reruns them on the other worker."""
    import dask
    from distributed import Client, LocalCluster

    from aerosurvey.campaign.run import dask_results, run_campaign

    out = tmp_path / "campaign"
    with dask.config.set({"distributed.scheduler.allowed-failures": allowed_failures}), \
            LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0") as cluster, \
            Client(cluster) as client:
        report = _kill_one_worker_when(3, lambda: list(client.run(os.getpid).values()))
        results, tally = run_campaign(_jobs(inputs), out, dask_results(client), report)
    assert report.state["killed"]
    failed = [r for r in results if r.status == "failed"]
    assert all("KilledWorker" in r.message or "workers running it died" in r.message for r in failed), failed
    if allowed_failures == 3:
        assert not failed
    assert tally.done + tally.failed == N_BLOCKS
    campaign_plan(*inputs, out, "--workers", "2")
    cc.same_campaign(out, reference)


def test_second_attempt_of_a_block_drops_its_copy(inputs, tmp_path, monkeypatch):
    """Two attempts of one block: the one that renames second finds the folder and keeps it, its own copy
    dropped; the folder is the first attempt's, whole."""
    from aerosurvey.campaign import job as job_module

    jobs = _jobs(inputs)[:1]
    out = tmp_path / "campaign"
    real_rename = os.rename
    first = {}

    def rename_after_another_attempt(src, dst):
        if not first:  # the other attempt (a retried task, a killed driver's worker) finishes first
            monkeypatch.setattr(job_module.os, "rename", real_rename)
            first["result"] = job_module.plan_block(jobs[0], str(out))
        return real_rename(src, dst)

    monkeypatch.setattr(job_module.os, "rename", rename_after_another_attempt)
    result = job_module.plan_block(jobs[0], str(out))
    assert result.status == first["result"].status == "planned" and result.record == first["result"].record
    folders = list((out / "blocks").iterdir())
    assert [p.name for p in folders] == [jobs[0].folder]
    assert sorted(p.name for p in folders[0].iterdir()) == ["block.json", "manifest.json", "mission.plan", "mission.waypoints",
                                                             "outline.geojson"]


def test_an_attempt_ending_in_an_exception_is_a_failed_block(inputs, tmp_path):
    """Whatever an attempt ends with (a bug's exception, a broken pool, Dask's KilledWorker) the block is
    reported failed with it, and the rest of the campaign goes on."""
    from concurrent.futures.process import BrokenProcessPool

    from aerosurvey.campaign.job import plan_block
    from aerosurvey.campaign.run import run_campaign

    class KilledWorker(Exception):  # noqa: N818  (Dask's name)
        pass

    raised = {1: ValueError("a bug"), 2: BrokenProcessPool("gone"), 3: KilledWorker("block-x", "tcp://w")}

    def executor(jobs, campaign):
        for i, job in enumerate(jobs):
            yield job, raised[i] if i in raised else plan_block(job, campaign)

    jobs = _jobs(inputs)[:5]
    results, tally = run_campaign(jobs, tmp_path / "c", executor)
    assert [r.status for r in results] == ["planned", "failed", "failed", "failed", "planned"]
    assert results[1].message == "ValueError: a bug"
    assert "the worker process running it died" in results[2].message
    assert "Dask gave up after distributed.scheduler.allowed-failures" in results[3].message
    assert (tally.done, tally.failed, tally.remaining) == (2, 3, 0)


def test_the_templates_limits_refuse_a_block_recorded_failed(tmp_path):
    """The template's [limits] hold for every block as for one plan: a block beyond them (t01, at a GSD that needs
    about six times the photos) is failed in the register with the limit named, the others are planned, and the
    rerun tries it again (a limit raised in the template is a new key, so it is planned then)."""
    blocks = cc.write_blocks(tmp_path / "blocks.geojson", 3, props={1: {"gsd_cm": 1.0}})
    free = tmp_path / "free"
    campaign_plan(blocks, cc.write_template(tmp_path), free, "--workers", "1")
    photos = {r["name"]: r["photos"] for r in cc.register(free)[0]}
    assert photos["t01"] > 3 * photos["t00"]
    limit = (photos["t01"] + photos["t00"]) // 2
    limited = tmp_path / "limits"
    limited.mkdir()
    out = tmp_path / "campaign"
    text = campaign_plan(blocks, cc.write_template(limited, limits={"max_photos": limit}), out, "--workers", "1", code=1)
    assert "1 block(s) failed (t01)" in text
    rows = {r["name"]: r for r in cc.register(out)[0]}
    assert {n: r["status"] for n, r in rows.items()} == {"t00": "planned", "t01": "failed", "t02": "planned"}
    assert f"more than limits.max_photos = {limit:,}" in rows["t01"]["message"] and rows["t01"]["photos"] == 0
    status = CliRunner().invoke(main, ["campaign", "status", str(out)]).output
    assert "t01: failed (the plan would take about" in status and "limits.max_photos" in status
    assert sorted(cc.block_folders(out)) == ["t00", "t02"]


def test_chunk_size_shares_a_task_and_feeds_every_worker():
    from aerosurvey.campaign.run import CHUNK_MAX, chunk_size

    for blocks in (0, 1, 7, 8, 20, 63, 64, 65, 1000, 10_000):
        for workers in (1, 2, 3, 16):
            size = chunk_size(blocks, workers)
            assert 1 <= size <= CHUNK_MAX
            if size > 1:  # several blocks a task only while every worker still gets four tasks or more
                assert -(-blocks // size) >= 4 * workers
    assert chunk_size(1000, 2) == CHUNK_MAX and chunk_size(20, 2) == 2 and chunk_size(7, 2) == 1


def test_a_chunk_of_no_block_is_refused(inputs, tmp_path):
    from aerosurvey.campaign.run import pool_results

    with pytest.raises(ValueError, match="chunk = 0: 1 or more blocks a task"):
        next(pool_results(2, chunk=0)(_jobs(inputs), str(tmp_path)))


@pytest.mark.parametrize("executor", ["pool", "dask"])
def test_tasks_of_several_blocks_give_the_same_campaign(inputs, reference, tmp_path, executor):
    """Chunks that do not divide the blocks evenly (3 and 7 of 20): every block planned once, its result
    given back in the jobs' order; the folders and the register as the reference's."""
    import contextlib

    from aerosurvey.campaign.run import dask_results, pool_results, run_campaign

    out = tmp_path / "campaign"
    jobs = _jobs(inputs)
    with contextlib.ExitStack() as stack:
        if executor == "pool":
            run = pool_results(2, chunk=3)
        else:
            from distributed import Client, LocalCluster

            cluster = stack.enter_context(LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0"))
            run = dask_results(stack.enter_context(Client(cluster)), chunk=7)
        results, tally = run_campaign(jobs, out, run)
    assert (tally.done, tally.failed, tally.skipped) == (N_BLOCKS, 0, 0)
    assert [(r.name, r.key, r.status) for r in results] == [(j.name, j.key, "planned") for j in jobs]
    assert sorted(cc.block_folders(out)) == [j.name for j in jobs]
    text = campaign_plan(*inputs, out, "--workers", "2")  # plans nothing: writes the register
    assert f"{N_BLOCKS} done ({N_BLOCKS} earlier), 0 failed, 0 remaining" in text
    cc.same_campaign(out, reference)


def test_a_block_done_before_its_task_failed_is_done(inputs, tmp_path):
    """A task whose worker died after some of its blocks were renamed into place: those are done (their
    block.json read), the others failed."""
    from concurrent.futures.process import BrokenProcessPool

    from aerosurvey.campaign.job import plan_block
    from aerosurvey.campaign.run import run_campaign

    jobs = _jobs(inputs)[:3]

    def executor(todo, campaign):
        planned = plan_block(todo[0], campaign)  # the first block's folder in place, then the worker dies
        assert planned.status == "planned"
        for job in todo:
            yield job, BrokenProcessPool("gone")

    results, tally = run_campaign(jobs, tmp_path / "c", executor)
    assert [r.status for r in results] == ["planned", "failed", "failed"]
    assert results[0].record == json.loads((tmp_path / "c" / "blocks" / jobs[0].folder / "block.json").read_text())
    assert all("the worker process running it died" in r.message for r in results[1:])
    assert (tally.done, tally.failed) == (1, 2)


def test_the_local_cluster_runs_its_workers_without_the_profiler(inputs, tmp_path):
    """`--dask local` starts its workers without Dask's statistical profiler (its hour of history grows a
    worker's memory with the run's length); the campaign runs on them."""
    import dask
    from distributed import default_client

    from aerosurvey.campaign.run import executor, run_campaign

    def profiler(dask_worker):
        return dask.config.get("distributed.worker.profile.enabled"), len(dask_worker.profile_history)

    with executor(2, dask="local") as run:
        results, tally = run_campaign(_jobs(inputs)[:3], tmp_path / "c", run)
        time.sleep(1.5)  # a profiler would have summed up a second by now
        assert list(default_client().run(profiler).values()) == [(False, 0), (False, 0)]
    assert tally.done == 3
