"""The threads ogacq starts leave Ctrl-C to the main thread.

A SIGINT sent to a process is delivered to any one of its threads that does not block
it (POSIX, "Signal Generation and Delivery"; Linux prefers the main thread but takes
another when the main one has a signal pending). Python runs its handlers in the main
thread only, and only between bytecodes: a main thread blocked reading the operator's
answer (``input()``) is woken only when the signal lands on it. Landed on a worker, the
Ctrl-C waits until the next key is pressed. Every thread of the simulator, the gauge
lines and the session's fsync therefore blocks SIGINT first thing; the threads it starts
inherit the mask (``pthread_sigmask``: a new thread takes its creator's)."""

from __future__ import annotations

import signal

__all__ = ["leave_interrupts_to_the_main_thread"]


def leave_interrupts_to_the_main_thread() -> None:
    """Block SIGINT in the calling thread (a worker: never the main one)."""
    signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
