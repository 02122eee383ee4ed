"""The one figure of a machine's calibrations over time, drawn for `ogacq history
--plot` and for the report's history section alike.

One panel per parameter: its value at each calibration with its expanded
uncertainty U (k = 2) as error bars; where U is unknown, 2 std of the fit stand in
(a hollow marker, as the drift flags judge it: ``drift.expanded``), and where
neither is known no bar is drawn and the point says so. Each parameter in the unit
the history's table states it in (``entries.parameter_unit``: a length in mm, as the
controller, the write-back and the record state an offset; it was drawn in µm beside a
table in mm). Optionally marked: the
write-backs between calibrations (the value as found, then as left), the flagged
drifts from the state as left, and the calibration a report is about. Drawn on
matplotlib's Agg canvas (no display needed)."""

from __future__ import annotations

import io
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from ogacq.history.drift import Drift, expanded
from ogacq.history.entries import Parameter, parameter_unit, parameters_in
from ogacq.io.atomic import write_atomically
from ogacq.io.dates import wall_time
from ogacq.record.calibration_record import CalibrationRecord
from ogacq.record.sections import named_results

DPI = 110
VALUE_COLOUR = "#1f5fa8"
CURRENT_COLOUR = "#D55E00"
WRITTEN_COLOUR = "#2e8b57"
DRIFT_COLOUR = "#c0392b"


class PlottedCalibration(Protocol):
    """What the figure reads of a calibration: the history's ``Calibration`` (store.py)
    and a record's ``RecordedCalibration`` both are one."""

    @property
    def record_id(self) -> str: ...
    @property
    def date(self) -> str | None: ...
    @property
    def parameters(self) -> Mapping[str, Parameter]: ...


@dataclass(frozen=True)
class RecordedCalibration:
    """A calibration as a record states it: one of its ``history`` entries or itself."""

    record_id: str
    date: str | None
    parameters: Mapping[str, Parameter]


def recorded_calibrations(record: Mapping[str, Any] | CalibrationRecord
                          ) -> list[RecordedCalibration]:
    """The earlier calibrations a record holds (``history``), then the record's own,
    each with its parameters read as the history reads them (``parameters_in``);
    oldest first when every one is dated (a caller's history may come in any order)."""
    typed = record if isinstance(record, CalibrationRecord) \
        else CalibrationRecord.from_json(record)
    entries = [*typed.history_entries, typed.as_history_entry()]
    found = [RecordedCalibration(str(e.id), e.date or None,
                                 {p.name: p for p in parameters_in(named_results(e.results))})
             for e in entries]
    dated = [(when, c) for c in found if (when := wall_time(c.date)) is not None]
    if len(dated) < len(found):
        return found
    return [c for _, c in sorted(dated, key=lambda pair: pair[0])]  # stable: ties as given


def history_figure(title: str, calibrations: Sequence[PlottedCalibration],
                   drifts: Sequence[Drift] = (),
                   written: Mapping[str, Mapping[str, float]] | None = None,
                   current: str | None = None) -> Figure:
    """The calibrations in the order given (oldest first), on their dates when every
    one has a date, else numbered; ``current``: the record id marked as "this
    calibration" (a report's)."""
    names = list(dict.fromkeys(n for c in calibrations for n in c.parameters))
    fig = Figure(figsize=(7.5, 1.2 + 2.0 * max(len(names), 1)), layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(max(len(names), 1), 1, sharex=True, squeeze=False)[:, 0]
    dated = [(c, wall_time(c.date)) for c in calibrations]
    by_date = all(when is not None for _, when in dated)
    xs_of = [when if by_date else index + 1 for index, (_, when) in enumerate(dated)]
    index_of = {c.record_id: index for index, c in enumerate(calibrations)}
    # the title holds a machine's name as given: '$' in it is text, not mathtext (a
    # name with "$...$" stopped the figure with a ParseSyntaxException)
    fig.suptitle(title, fontsize=11, parse_math=False)
    for ax, name in zip(axes, names, strict=False):
        unit = parameter_unit(name)
        xs: list[Any] = []
        ys, errs, guessed, unknown = [], [], [], []
        for index, c in enumerate(calibrations):
            p = c.parameters.get(name)
            if p is None:
                continue
            u, basis = expanded(p)
            xs.append(xs_of[index])
            ys.append(p.value_mm)
            errs.append(u or 0.0)
            guessed.append(u is not None and basis != "U")
            unknown.append(u is None)
            if current is not None and c.record_id == current:
                ax.plot([xs[-1]], [ys[-1]], "o", mfc="none", mec=CURRENT_COLOUR, mew=2,
                        ms=11, zorder=6, label="this calibration")
        ax.errorbar(xs, ys, yerr=errs, fmt="o-", color=VALUE_COLOUR, ecolor="#6b8fc4",
                    capsize=4, lw=1.2, ms=5, label="value ± U")
        if any(guessed):
            ax.plot([x for x, g in zip(xs, guessed, strict=True) if g],
                    [y for y, g in zip(ys, guessed, strict=True) if g], "o", mfc="white",
                    mec=VALUE_COLOUR, ms=5, zorder=5, label="U unknown: ± 2 std")
        for x, y, none in zip(xs, ys, unknown, strict=True):
            if none:  # said on the figure, not drawn as a zero bar
                ax.annotate("U not evaluated", (x, y), xytext=(6, 0), textcoords="offset points",
                            va="center", fontsize=8, color="#6b7680")
        for index, c in enumerate(calibrations):
            wrote = (written or {}).get(c.record_id, {}).get(name)
            p = c.parameters.get(name)
            if wrote is None or p is None or index == len(calibrations) - 1:
                continue
            x = xs_of[index]
            ax.plot([x, x], [p.value_mm, p.value_mm + wrote], "--",
                    color=WRITTEN_COLOUR, lw=1.5, zorder=3)
            ax.plot([x], [p.value_mm + wrote], "^", color=WRITTEN_COLOUR, ms=7,
                    zorder=5, label="as left by a write-back")
        for d in drifts:
            if d.parameter != name or not d.flagged:
                continue
            i, j = index_of[d.from_record], index_of[d.to_record]
            y0 = calibrations[i].parameters[name].value_mm + d.shift_mm
            y1 = calibrations[j].parameters[name].value_mm
            ax.plot([xs_of[i], xs_of[j]], [y0, y1], "-", color=DRIFT_COLOUR, lw=2.5, zorder=4,
                    label="change > U of the change")
        ax.set_ylabel(f"{name}\n({unit})", fontsize=9)
        # the values as the table writes them (1.3505), never "1e-3 + 1.35" on the axis
        ax.ticklabel_format(axis="y", style="plain", useOffset=False)
        ax.grid(True, alpha=0.3)
        ax.margins(x=0.08, y=0.25)
        handles, labels = ax.get_legend_handles_labels()
        unique = dict(zip(labels, handles, strict=True))
        ax.legend(unique.values(), unique.keys(), fontsize=8, loc="best")
    axes[-1].set_xlabel(("calibration date" if by_date else "calibration")
                        + "; error bars: expanded uncertainty U (k = 2)")
    if by_date:
        fig.autofmt_xdate()
    return fig


def png_of(figure: Figure) -> bytes:
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=DPI)
    return buffer.getvalue()


def write_history_plot(path: Path, title: str, calibrations: Sequence[PlottedCalibration],
                       drifts: Sequence[Drift],
                       written: Mapping[str, Mapping[str, float]] | None = None) -> Path:
    # drawn whole, then written whole (a full disk leaves no half PNG)
    write_atomically(path, png_of(history_figure(title, calibrations, drifts, written)))
    return path
