"""A policy's calls, guarded: an error, a bad action or a slow step ends its episode.

The episode ends as a failure with the reason, and the run goes on to the next episode.
"""

from __future__ import annotations

import signal
import threading
import time
from contextlib import contextmanager

import numpy as np

ACT_LIMIT_S = 10.0  # s per call of reset or act; our policies take under 0.1 s a step

# Failure reasons an episode's record can carry (besides the env's "success", "stuck" and
# "time limit"); the record's ``failure`` says what exactly.
NOT_LOADED = "policy not loaded"
RAISED = "policy raised"
INVALID_ACTION = "invalid action"
TOO_SLOW = "policy too slow"
DIED = "policy process died"  # a policy in its own process (servo.task.remote)
GARBAGE = "policy sent garbage"  # an answer that is no message of servo.task.wire
FAILURES = (NOT_LOADED, RAISED, INVALID_ACTION, TOO_SLOW, DIED, GARBAGE)


class PolicyFailure(Exception):
    """A policy's episode ended by the policy.

    Parameters
    ----------
    reason : str
        One of [`FAILURES`][servo.task.guard.FAILURES].
    detail : str
        What happened.

    Attributes
    ----------
    reason, detail
        The parameters.
    """

    def __init__(self, reason: str, detail: str):
        super().__init__(f"{reason}: {detail}")
        self.reason, self.detail = reason, detail


class _Overtime(BaseException):
    """Raised into a policy's call by the alarm.

    A BaseException, so that a policy's own ``except Exception`` does not swallow it.
    """


def _on_alarm(signum, frame):
    raise _Overtime


@contextmanager
def _alarm(seconds: float):
    # SIGALRM interrupts a policy stuck in Python code; it exists on POSIX and only the main
    # thread may set it. Elsewhere the call's time is checked when it returns.
    main = threading.current_thread() is threading.main_thread()
    if not (main and hasattr(signal, "setitimer")):
        yield
        return
    previous = signal.signal(signal.SIGALRM, _on_alarm)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


def call(fn, *args, limit: float = ACT_LIMIT_S):
    """Return ``fn(*args)``, guarded.

    Raises [`PolicyFailure`][servo.task.guard.PolicyFailure] when ``fn`` raises or takes over
    ``limit`` s.

    Parameters
    ----------
    fn : callable
        The policy's method.
    *args
        Its arguments.
    limit : float, default ACT_LIMIT_S
        Seconds the call may take.

    Returns
    -------
    object
        What ``fn`` returned.
    """
    t0 = time.perf_counter()
    try:
        with _alarm(limit):
            out = fn(*args)
    except PolicyFailure:  # a policy in its own process: the boundary said what went wrong
        raise
    except _Overtime:
        raise PolicyFailure(TOO_SLOW, f"{_name(fn)} took over {limit:g} s") from None
    except Exception as err:
        raise PolicyFailure(RAISED, f"{_name(fn)} raised {type(err).__name__}: {err}") from err
    took = time.perf_counter() - t0
    if took > limit:
        raise PolicyFailure(TOO_SLOW, f"{_name(fn)} took {took:.3g} s, over {limit:g} s")
    return out


def _name(fn) -> str:
    return getattr(fn, "__qualname__", None) or type(fn).__name__


def check_action(action, low: np.ndarray, high: np.ndarray) -> None:
    """Raise [`PolicyFailure`][servo.task.guard.PolicyFailure] unless ``action`` is valid.

    A valid action is two finite numbers inside ``[low, high]`` (the env's action space).

    Parameters
    ----------
    action : array_like
        The policy's action.
    low, high : ndarray of shape (2,)
        The action space's bounds.
    """
    try:
        a = np.asarray(action, dtype=np.float64)
    except (TypeError, ValueError):
        raise PolicyFailure(INVALID_ACTION, f"not numbers: {action!r}") from None
    if a.shape != low.shape:
        raise PolicyFailure(INVALID_ACTION, f"shape {a.shape}, expected {low.shape}")
    if not np.isfinite(a).all():
        raise PolicyFailure(INVALID_ACTION, f"not finite: {a.tolist()}")
    if (a < low).any() or (a > high).any():
        raise PolicyFailure(
            INVALID_ACTION, f"{a.tolist()} outside [{low.tolist()}, {high.tolist()}]"
        )
