"""Deterministic numbers: elastyle's products run on one BLAS thread, so a transfer gives the same bytes
whatever thread count the machine or the user's environment sets (a multi-threaded BLAS sums in another
order, which moves values near 1e-4 after the decoder). Batches use processes for parallelism instead, and
`stop_workers` ends them at once on Ctrl-C or a kill.

BLAS's thread limit is the whole process's, so calls made from several of a user's threads run one at a time:
overlapping, they fought over it (a call ran on two BLAS threads, its output off by 1e-7, and the limit of one
stayed on the process after the last call ended).
"""

from __future__ import annotations

import multiprocessing
import os
import threading
from collections.abc import Callable
from concurrent.futures import Executor
from functools import cache, wraps
from typing import ParamSpec, TypeVar

from threadpoolctl import ThreadpoolController

_ONE_CALL_AT_A_TIME = threading.RLock()  # a call may call another (a transfer prepares its style)


def _fresh_lock_after_fork() -> None:
    """A forked child gets its own lock: one held by another thread at the fork would never be released."""
    global _ONE_CALL_AT_A_TIME
    _ONE_CALL_AT_A_TIME = threading.RLock()


if hasattr(os, "register_at_fork"):  # POSIX
    os.register_at_fork(after_in_child=_fresh_lock_after_fork)

Params = ParamSpec("Params")
Result = TypeVar("Result")


@cache
def _controller() -> ThreadpoolController:
    """The loaded thread pools, found once per process (finding them costs about 0.3 ms, a limit on a
    known controller 0.01 ms): numpy's BLAS, the one transfers use, is loaded with numpy."""
    return ThreadpoolController()


def one_blas_thread(function: Callable[Params, Result]) -> Callable[Params, Result]:
    """Run `function` with the BLAS libraries limited to one thread (restored afterwards), one call at a time
    in the process."""

    @wraps(function)
    def limited(*args: Params.args, **kwargs: Params.kwargs) -> Result:
        with _ONE_CALL_AT_A_TIME, _controller().limit(limits=1, user_api="blas"):
            return function(*args, **kwargs)

    return limited


def usable_cores() -> int:
    """The cores this process may run on: its CPU affinity where the system tells it, else the machine's."""
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1


def stop_workers(pool: Executor) -> None:
    """A process pool's queued tasks dropped and its working processes ended now (on Ctrl-C or a kill: the
    command's, which then reports it; waiting would run every queued task first)."""
    pool.shutdown(wait=False, cancel_futures=True)
    for worker in multiprocessing.active_children():
        worker.terminate()
