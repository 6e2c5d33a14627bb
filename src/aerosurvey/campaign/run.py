"""The campaign's driver: the blocks not yet done handed to an executor, results streamed back.

Executors run `job.plan_blocks` on chunks of picklable jobs (a task plans up to CHUNK_MAX blocks
one after the other, `chunk_size`) and yield (job, result or the exception the attempt ended with)
as tasks finish, with a bounded number of tasks in flight: the driver holds the jobs and the small
result records, never a plan.

- `pool_results`: a local process pool (concurrent.futures). A worker process that dies breaks
  the pool: the blocks it held come back failed and a new pool takes the rest.
- `dask_results`: Dask distributed (`Client.submit`, `as_completed`). The scheduler reruns a
  task whose worker died, and gives up with KilledWorker once the task has been on
  `distributed.scheduler.allowed-failures` (default 3) workers that died; the block then comes back
  failed. Each task's key is its first block's key, so each block is in one task.

Whichever ran it, a block is done when its folder is renamed into place (job.py), so a rerun
plans exactly the blocks that are not; a block of a task that ended with an exception (its worker
died) whose folder is in place is done, the others failed.
"""

from __future__ import annotations

import contextlib
import logging
import time
from collections.abc import Callable, Iterator
from concurrent import futures
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, field
from itertools import islice
from pathlib import Path
from typing import Any

from aerosurvey.campaign.job import BLOCKS_DIR, RESULT_FILE, BlockJob, BlockResult, clean_temporary, plan_blocks, read_result
from aerosurvey.errors import InputError

log = logging.getLogger(__name__)

Outcome = tuple[BlockJob, "BlockResult | BaseException"]
Executor = Callable[[list[BlockJob], str], Iterator[Outcome]]


#: the most blocks one task plans (`chunk_size`)
CHUNK_MAX = 8


def chunk_size(blocks: int, workers: int) -> int:
    """How many blocks one task plans: up to CHUNK_MAX, so a task's cost to the executor (a few
    milliseconds on a Dask worker and its scheduler, measured in benchmarks/campaign_bench.py) is
    shared by several blocks, and few enough that each worker gets at least four tasks (the last
    tasks leave the other workers idle for less)."""
    return max(1, min(CHUNK_MAX, blocks // (4 * workers)))


def _chunks(jobs: list[BlockJob], size: int | None, workers: int) -> Iterator[list[BlockJob]]:
    """The jobs in tasks of `size` (`chunk_size` if None) blocks, the last perhaps fewer."""
    size = chunk_size(len(jobs), workers) if size is None else size
    if size < 1:
        raise ValueError(f"chunk = {size}: 1 or more blocks a task")
    return (jobs[i:i + size] for i in range(0, len(jobs), size))


def _outcomes(chunk: list[BlockJob], result: Callable[[], list[BlockResult | Exception]]) -> list[Outcome]:
    """Each job of a task's chunk with its outcome: the task's, or the exception the whole task ended with."""
    try:
        return list(zip(chunk, result(), strict=True))
    except Exception as exc:  # the task's end (a worker that died), the outcome of each of its blocks
        return [(job, exc) for job in chunk]


def pool_results(workers: int, chunk: int | None = None) -> Executor:
    """An executor on a local process pool of `workers` processes, `chunk` blocks a task (`chunk_size` if None)."""

    def run(jobs: list[BlockJob], campaign: str) -> Iterator[Outcome]:
        # the planner imported once here, before the workers fork: each has it without importing it again
        import aerosurvey.inputs
        import aerosurvey.outputs  # noqa: F401

        todo = _chunks(jobs, chunk, workers)
        window = 2 * workers
        while True:
            with futures.ProcessPoolExecutor(max_workers=workers) as pool:
                running = {pool.submit(plan_blocks, c, campaign): c for c in islice(todo, window)}
                broken = False
                while running:
                    done, _ = futures.wait(running, return_when=futures.FIRST_COMPLETED)
                    for f in done:
                        outcomes = _outcomes(running.pop(f), f.result)
                        broken = broken or isinstance(f.exception(), BrokenProcessPool)
                        if not broken:  # the next task handed out before the driver takes these results
                            running |= {pool.submit(plan_blocks, c, campaign): c for c in islice(todo, 1)}
                        yield from outcomes
            if not broken:
                return
            log.warning("a worker process died: the blocks it held are reported failed, a new pool takes the rest")

    return run


def dask_results(client: Any, chunk: int | None = None) -> Executor:
    """An executor on a Dask distributed client (a LocalCluster's or a scheduler's), `chunk` blocks a
    task (`chunk_size` if None)."""

    def run(jobs: list[BlockJob], campaign: str) -> Iterator[Outcome]:
        from distributed import as_completed

        workers = max(1, sum(client.nthreads().values()))
        todo = _chunks(jobs, chunk, workers)
        by_key: dict[str, list[BlockJob]] = {}

        def submit(c: list[BlockJob]) -> Any:
            key = f"blocks-{c[0].key}"  # a block is in one task: its first block's key names it
            by_key[key] = c
            return client.submit(plan_blocks, c, campaign, key=key, pure=False, retries=0)

        stream = as_completed([submit(c) for c in islice(todo, 2 * workers)], with_results=False)  # type: ignore[no-untyped-call]
        for f in stream:
            outcomes = _outcomes(by_key.pop(f.key), f.result)  # KilledWorker: each of its blocks
            f.release()
            for nxt in islice(todo, 1):  # the next task handed out before the driver takes these results
                stream.add(submit(nxt))  # type: ignore[no-untyped-call]
            yield from outcomes

    return run


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
            done = blocks / job.folder  # renamed into place before the task's worker died
            outcome = read_result(job, done) if (done / RESULT_FILE).is_file() else \
                BlockResult(job.name, job.key, "failed", message=_failure(outcome))
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



#: Dask settings of the LocalCluster `--dask local` starts: no statistical profiler in the workers (it
#: samples every thread's stack every 10 ms and keeps an hour of 1-second summaries, ~36 kB a
#: second of a worker planning blocks, pickled: the workers' memory would grow with the run's length)
LOCAL_CLUSTER_CONFIG = {"distributed.worker.profile.enabled": False}


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
    from dask import config as dask_config  # (`dask` is the option's value here)

    with dask_config.set(LOCAL_CLUSTER_CONFIG):  # the workers' nannies pass it on to them
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,  # type: ignore[no-untyped-call]
                               dashboard_address=":0")
    with cluster, Client(cluster) as client:  # type: ignore[no-untyped-call]
        yield dask_results(client)
