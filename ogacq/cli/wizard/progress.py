"""The automatic Zero/Max/Min cycles, shown as they run: one bar per leg with
the cycle, the posture and the last value read."""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence

from rich.progress import Progress, TaskID

from ogacq.cli.plain import bar_of
from ogacq.cli.wizard.by_eye import ReadingCounter
from ogacq.cli.wizard.ui import Screen, times
from ogacq.protocol import runner
from ogacq.protocol.plan import ProtocolConfig, Read


class CycleProgress:
    """The runner's observer."""

    def __init__(self, screen: Screen, steps: Sequence[Read], config: ProtocolConfig,
                 counter: ReadingCounter, recorded: set[tuple[str, str]]) -> None:
        self.screen = screen
        self.config = config
        self.counter = counter
        self._by_id = {s.step: s for s in steps}
        self._leg_total = Counter({leg: 0 for leg in config.legs})
        for s in steps:
            self._leg_total[s.leg] += len(s.gauges)
        self._leg_done = Counter(self._by_id[step].leg for step, _ in recorded
                                 if step in self._by_id)
        self._bar: Progress | None = None
        self._task = TaskID(0)
        self._leg = ""
        self._last = ""

    def __call__(self, progress: runner.Progress) -> None:
        self.counter.done, self.counter.total = progress.done, progress.total
        step_id, _, value = progress.message.partition(" ")
        step = self._by_id.get(step_id)
        if step is None:  # "gauges set on the x leg"
            return
        self._leg_done[step.leg] += 1
        self._last = (f"cycle {step.cycle} of {self.config.cycles} · {step.posture.title()}"
                      f" · {value}")
        self._show(step.leg)
        if self._leg_done[step.leg] >= self._leg_total[step.leg]:
            self.screen.stop_live()
            self._bar = None
            self.screen.ok(f"{step.leg} leg measured: {self._leg_total[step.leg]} readings, "
                           f"{times(self.config.cycles, 'cycle')} "
                           f"({progress.done} of {progress.total} in all)")

    def pausing(self) -> None:
        """Ctrl-C was pressed during a move or a read: say the pause is coming."""
        if self._bar is not None:
            self._bar.update(self._task, last="[yellow]pausing at the next step … "
                             "(Ctrl-C again: stop at once)[/]")

    def _show(self, leg: str) -> None:
        if self._bar is None or self._leg != leg or self.screen.live is not self._bar:
            self._bar = bar_of("[bold]{task.description}[/]", console=self.screen.out,
                               transient=True, last=True)
            self._task = self._bar.add_task(f"{leg} leg", total=self._leg_total[leg], last="")
            self._leg = leg
            self.screen.show_live(self._bar)
        self._bar.update(self._task, completed=self._leg_done[leg], last=self._last)
