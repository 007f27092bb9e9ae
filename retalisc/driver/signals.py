"""SIGTERM and SIGINT during a run of the Python driver (docs/runtime.md, "Signals, exit
statuses, a full disk, event types"): the run ends as at the end of its input, without the rest of it. A
batch being processed is finished (its output written, its journal record and snapshot
taken), never cut: the signal is only noted while a batch is in hand, and ends the
run (`SignalStop`) when the batch is done, or at once while the run waits for input. The run
then flushes its output, prints the summary and exits with 128 + the signal's number, the
status a shell reports for a process the signal killed, as `swipl PROGRAM.pl` does
(prolog_runtime/retalis.pl, stop_on_signal/1). When the runtime's own loop reads the input
(prolog_runtime/rtl_feed.pl, rtl_run_event_file/4) its Prolog handlers take the signals while it runs, and it reports the
signal that stopped it (`stopped_by`).
"""
from __future__ import annotations

import signal
import threading
from typing import Optional

STOP_SIGNALS = (signal.SIGTERM, signal.SIGINT)


class SignalStop(Exception):
    """A stop signal ends the run (`SignalStops.status` gives its exit status)."""

    def __init__(self, signum: int):
        super().__init__(signal.Signals(signum).name)


class SignalStops:
    """The stop signals during one run: after `install()` they end the run (SignalStop), but
    not between `batch_starts()` and `batch_ends()` (which raises SignalStop for one that came
    meanwhile); `restore()` puts the previous handlers back. Outside the main thread (where
    Python takes no signals) it changes nothing."""

    def __init__(self):
        self.received: Optional[int] = None
        self._busy = False
        self._previous = {}

    def install(self) -> None:
        if threading.current_thread() is threading.main_thread():
            for signum in STOP_SIGNALS:
                self._previous[signum] = signal.signal(signum, self._handle)

    def restore(self) -> None:
        for signum, handler in self._previous.items():
            signal.signal(signum, handler)
        self._previous.clear()

    def _handle(self, signum, frame) -> None:
        if self.received is None:
            self.received = signum
        if not self._busy:
            self._busy = True                    # what follows (flush, summary) is not cut
            raise SignalStop(signum)

    def batch_starts(self) -> None:
        self._busy = True

    def batch_ends(self) -> None:
        if self.received is not None:
            raise SignalStop(self.received)
        self._busy = False

    def retake(self) -> None:
        """Install these handlers again after a loop run by Prolog, whose own handlers took
        the stop signals while it ran."""
        for signum in self._previous:
            signal.signal(signum, self._handle)

    def stopped_by(self, signum: int) -> None:
        """The signal `signum` stopped a loop run by Prolog: end the run."""
        self.received = signum
        self._busy = True
        raise SignalStop(signum)

    def finishing(self) -> None:
        """From now on (the end of the run) a stop signal is only noted."""
        self._busy = True

    def status(self, status: int) -> int:
        """The exit status of a run that would end with `status`: that of the stop signal
        received, if one was."""
        return 128 + self.received if self.received is not None else status
