"""Plans run as jobs: a page can follow their progress, cancel them, and keep typing.

Jobs run on a small thread pool. Cancelling is cooperative: the planner reports progress
between its steps, and the report raises `Cancelled` once the job is cancelled, so a
cancelled plan stops at its next step and leaves nothing behind.
"""

from __future__ import annotations

import itertools
import logging
import threading
import time
from collections import OrderedDict
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import Any

from aerosurvey.errors import AerosurveyError, InputError

log = logging.getLogger(__name__)

#: A job's progress report: stage name, share done (0..1); the planner's `Progress`.
Progress = Callable[[str, float], None]


class Cancelled(Exception):
    """The job was cancelled; raised from inside its progress report."""


class QueueFull(Exception):
    """As many jobs wait for a worker as the runner queues: the new one is refused (HTTP 429)."""


@dataclass
class Job:
    id: str
    state: str = "queued"  # queued, running, done, error, cancelled
    stage: str = "queued"
    progress: float = 0.0
    result: Any = None
    error: dict[str, Any] | None = None
    started: float = field(default_factory=time.monotonic)
    finished: float | None = None
    cancel: threading.Event = field(default_factory=threading.Event)
    done: threading.Event = field(default_factory=threading.Event)
    # what the job runs, dropped once it runs or is cancelled: a cancelled job waiting for a thread holds no spec
    work: Callable[[Progress], Any] | None = field(default=None, repr=False)

    def report(self, stage: str, share: float) -> None:
        if self.cancel.is_set():
            raise Cancelled()
        self.stage, self.progress = stage, max(self.progress, min(1.0, share))

    def status(self) -> dict[str, Any]:
        end = self.finished if self.finished is not None else time.monotonic()
        return {"id": self.id, "state": self.state, "stage": self.stage, "progress": round(self.progress, 3),
                "elapsed_s": round(end - self.started, 3), "error": self.error}


class JobRunner:
    """Runs jobs on `workers` threads, at most `max_waiting` of them waiting for a thread (cancelled ones
    not counted: they end as soon as a thread takes them), and keeps the last `keep` finished ones for
    their results."""

    def __init__(self, workers: int = 2, keep: int = 16, max_waiting: int = 8):
        self._pool = ThreadPoolExecutor(max_workers=workers, thread_name_prefix="aerosurvey-job")
        self._workers = workers
        self._max_waiting = max_waiting
        self._jobs: OrderedDict[str, Job] = OrderedDict()
        self._lock = threading.Lock()
        self._ids = itertools.count(1)
        self._keep = keep

    def submit(self, fn: Callable[[Progress], Any]) -> Job:
        """Queue a job; QueueFull when `max_waiting` jobs already wait."""
        with self._lock:
            waiting = sum(j.state == "queued" and not j.cancel.is_set() for j in self._jobs.values())
            if waiting >= self._max_waiting:
                raise QueueFull(f"{waiting} plans are already waiting for the server's {self._workers} planning "
                                f"thread(s), the most it queues; wait for one to finish or cancel one (DELETE /api/jobs/ID)")
            job = Job(id=f"j{next(self._ids)}", work=fn)
            self._jobs[job.id] = job
            while len(self._jobs) > self._keep:
                oldest = next(iter(self._jobs))
                if not self._jobs[oldest].done.is_set():
                    break
                self._jobs.pop(oldest)
        self._pool.submit(self._run, job)
        return job

    def _run(self, job: Job) -> None:
        try:
            fn, job.work = job.work, None
            if job.cancel.is_set() or fn is None:
                raise Cancelled()
            job.state = "running"
            job.started = time.monotonic()
            result = fn(job.report)
            if job.cancel.is_set():
                raise Cancelled()
            job.result, job.state = result, "done"
        except Cancelled:
            job.state, job.stage = "cancelled", "cancelled"
        except AerosurveyError as exc:
            job.state = "error"
            job.error = {"message": str(exc), "key": getattr(exc, "key", None), "kind": "input" if isinstance(exc, InputError) else "check"}
        except Exception as exc:  # a defect: the page shows it, the server log keeps the traceback
            log.exception("plan job %s failed", job.id)
            job.state = "error"
            job.error = {"message": f"internal error: {type(exc).__name__}: {exc}", "key": None, "kind": "internal"}
        finally:
            job.finished = time.monotonic()
            job.done.set()

    def get(self, job_id: str) -> Job | None:
        with self._lock:
            return self._jobs.get(job_id)

    def cancel(self, job_id: str) -> Job | None:
        job = self.get(job_id)
        if job is not None:
            job.cancel.set()
            job.work = None
        return job

    def shutdown(self) -> None:
        with self._lock:
            for job in self._jobs.values():
                job.cancel.set()
        self._pool.shutdown(wait=True, cancel_futures=True)
