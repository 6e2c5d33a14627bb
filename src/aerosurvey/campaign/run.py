"""The campaign's driver: the blocks not yet done handed to an executor, results streamed back.

Executors run `job.plan_block` on picklable jobs and yield (job, result or the exception the
attempt ended with) as attempts finish, with a bounded number of blocks in flight: the driver
holds the jobs and the small result records, never a plan.

- `pool_results`: a local process pool (concurrent.futures). A worker process that dies breaks
  the pool: the blocks it held come back failed and a new pool takes the rest.
- `dask_results`: Dask distributed (`Client.submit`, `as_completed`). The scheduler reruns a
  task whose worker died, and gives up with KilledWorker once the task has been on
  `distributed.scheduler.allowed-failures` (default 3) workers that died; the block then comes back
  failed. Each task's key is the block's key, so one block is one task.

Whichever ran it, a block is done when its folder is renamed into place (job.py), so a rerun
plans exactly the blocks that are not.
"""

from __future__ import annotations

import contextlib
import logging
import time
from collections.abc import Callable, Iterator
from concurrent import futures
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from aerosurvey.campaign.job import BLOCKS_DIR, RESULT_FILE, BlockJob, BlockResult, clean_temporary, plan_block, read_result
from aerosurvey.errors import InputError

log = logging.getLogger(__name__)

Outcome = tuple[BlockJob, "BlockResult | BaseException"]
Executor = Callable[[list[BlockJob], str], Iterator[Outcome]]


def pool_results(workers: int) -> Executor:
    """An executor on a local process pool of `workers` processes."""

    def run(jobs: list[BlockJob], campaign: str) -> Iterator[Outcome]:
        # the planner imported once here, before the workers fork: each has it without importing it again
        import aerosurvey.inputs
        import aerosurvey.outputs  # noqa: F401

        todo = iter(jobs)
        window = 2 * workers
        while True:
            with futures.ProcessPoolExecutor(max_workers=workers) as pool:
                running: dict[futures.Future[BlockResult], BlockJob] = {}
                broken = False
                for job in _take(todo, window):
                    running[pool.submit(plan_block, job, campaign)] = job
                while running:
                    done, _ = futures.wait(running, return_when=futures.FIRST_COMPLETED)
                    for f in done:
                        job = running.pop(f)
                        try:
                            yield job, f.result()
                        except BrokenProcessPool as exc:
                            broken = True
                            yield job, exc
                        except Exception as exc:  # the block's own error, passed on as its outcome
                            yield job, exc
                        if not broken:
                            for nxt in _take(todo, 1):
                                running[pool.submit(plan_block, nxt, campaign)] = nxt
            if not broken:
                return
            log.warning("a worker process died: the blocks it held are reported failed, a new pool takes the rest")

    return run


def dask_results(client: Any) -> Executor:
    """An executor on a Dask distributed client (a LocalCluster's or a scheduler's)."""

    def run(jobs: list[BlockJob], campaign: str) -> Iterator[Outcome]:
        from distributed import as_completed

        workers = max(1, sum(client.nthreads().values()))
        todo = iter(jobs)
        by_key: dict[str, BlockJob] = {}

        def submit(job: BlockJob) -> Any:
            by_key[f"block-{job.key}"] = job
            return client.submit(plan_block, job, campaign, key=f"block-{job.key}", pure=False, retries=0)

        stream = as_completed([submit(j) for j in _take(todo, 2 * workers)], with_results=False)  # type: ignore[no-untyped-call]
        for f in stream:
            job = by_key.pop(f.key)
            try:
                yield job, f.result()
            except Exception as exc:  # KilledWorker, or the block's own error
                yield job, exc
            f.release()
            for nxt in _take(todo, 1):
                stream.add(submit(nxt))  # type: ignore[no-untyped-call]

    return run


def _take(it: Iterator[BlockJob], n: int) -> list[BlockJob]:
    out = []
    for job in it:
        out.append(job)
        if len(out) == n:
            break
    return out


@dataclass
class Tally:
    """Counts while the campaign runs, for the progress line."""

    total: int
    done: int = 0
    failed: int = 0
    skipped: int = 0
    started: float = field(default_factory=time.perf_counter)

    @property
    def remaining(self) -> int:
        return self.total - self.done - self.failed - self.skipped

    def text(self) -> str:
        elapsed = time.perf_counter() - self.started
        rate = self.done / elapsed if elapsed > 0 else 0.0
        return (f"{self.done + self.skipped} done ({self.skipped} earlier), {self.failed} failed, {self.remaining} remaining, "
                f"{rate:.1f} blocks/s")


def run_campaign(jobs: list[BlockJob], campaign: Path, executor: Executor,
                 progress: Callable[[str, float], None] | None = None) -> tuple[list[BlockResult], Tally]:
    """Plan every job whose folder is not there yet on `executor`; every job's result (in the
    jobs' order) and the tally. A block whose attempt ended with an exception is a "failed" result
    naming it; the campaign goes on."""
    blocks = campaign / BLOCKS_DIR
    blocks.mkdir(parents=True, exist_ok=True)
    left = clean_temporary(campaign)
    if left:
        log.info("removed %d temporary block folder(s) an interrupted run left", left)
    results: dict[str, BlockResult] = {}
    todo = []
    for job in jobs:
        folder = blocks / job.folder
        if (folder / RESULT_FILE).is_file():
            results[job.key] = read_result(job, folder)
        else:
            todo.append(job)
    tally = Tally(len(jobs), skipped=len(results))
    report = progress or (lambda stage, done: None)
    report(tally.text(), tally.skipped / max(1, tally.total))
    for job, outcome in executor(todo, str(campaign)):
        if isinstance(outcome, BaseException):
            outcome = BlockResult(job.name, job.key, "failed", message=_failure(outcome))
        if outcome.status == "failed":
            tally.failed += 1
            log.warning("block %s failed: %s", job.name, outcome.message)
        else:
            tally.done += 1
        results[job.key] = outcome
        report(tally.text(), 1 - tally.remaining / max(1, tally.total))
    return [results[j.key] for j in jobs], tally


def _failure(exc: BaseException) -> str:
    name = type(exc).__name__
    if name == "KilledWorker":
        return (f"the workers running it died ({exc}); Dask gave up after distributed.scheduler.allowed-failures: "
                "rerun `campaign plan` to plan it again")
    if isinstance(exc, BrokenProcessPool):
        return "the worker process running it died; rerun `campaign plan` to plan it again"
    return f"{name}: {exc}"



@contextlib.contextmanager
def executor(workers: int, dask: str | None = None, scheduler: str | None = None) -> Iterator[Executor]:
    """The executor `campaign plan` asked for: Dask on a LocalCluster of `workers` single-threaded
    worker processes (`dask` "local"), on the scheduler at `scheduler` (tcp://HOST:PORT), else a
    local process pool of `workers` processes."""
    if workers < 1:
        raise InputError(f"--workers = {workers} is not allowed: 1 or more")
    if dask is not None and scheduler is not None:
        raise InputError("--dask local and --scheduler are given together: give one executor")
    if dask is None and scheduler is None:
        yield pool_results(workers)
        return
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        raise InputError("--dask and --scheduler need Dask distributed: pip install 'aerosurvey[dask]'") from None
    if scheduler is not None:
        if not scheduler.startswith(("tcp://", "tls://", "inproc://", "ucx://")):
            raise InputError(f"--scheduler = {scheduler!r} is not allowed: a scheduler address such as tcp://HOST:8786",
                             key="--scheduler")
        try:
            client = Client(scheduler, timeout=30)  # type: ignore[no-untyped-call]
        except OSError as exc:
            raise InputError(f"--scheduler = {scheduler!r}: no Dask scheduler answers there ({exc})", key="--scheduler") from None
        with client:
            yield dask_results(client)
        return
    if not log.isEnabledFor(logging.DEBUG):  # the cluster's start and stop are news at -vv only
        logging.getLogger("distributed").setLevel(logging.WARNING)
    cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,  # type: ignore[no-untyped-call]
                           dashboard_address=":0")
    with cluster, Client(cluster) as client:  # type: ignore[no-untyped-call]
        yield dask_results(client)
