"""The history of a machine's calibrations: each parameter over time with its
expanded uncertainty U as error bars, this calibration marked.

The points come from the record (``record["history"]`` plus the record's own
results), so the figure shows exactly what ``record.json`` holds.
"""

from __future__ import annotations

import datetime as dt
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import matplotlib
import numpy as np
from matplotlib.figure import Figure

from ogacq.record.calibration_record import CalibrationRecord
from ogacq.report.figures import BEFORE_COLOUR, STYLE

CURRENT_COLOUR = "#D55E00"


@dataclass(frozen=True)
class HistoryPoint:
    record_id: str
    when: dt.datetime
    value_mm: float
    U_mm: float | None  # None: not evaluated for that calibration
    current: bool


def parse_date(text: str | None) -> dt.datetime | None:
    """An ISO 8601 date or date-time as recorded (``+0000`` offsets too), on the
    recorded wall clock: calibrations are ordered, not converted between zones."""
    if not text:
        return None
    try:
        return dt.datetime.fromisoformat(text).replace(tzinfo=None)
    except ValueError:
        return None


def history_points(record: Mapping[str, Any]) -> dict[str, list[HistoryPoint]]:
    """Per parameter (``joint_offset.x``), its values over time, oldest first; entries
    without a date or a value are left out (they cannot be placed)."""
    typed = CalibrationRecord.from_json(record)
    entries = [(e.get("id"), e.get("date"), e.get("results"), False)
               for e in typed.history or () if isinstance(e, Mapping)]
    entries.append((typed.id, typed.date, typed.results, True))
    out: dict[str, list[HistoryPoint]] = {}
    for record_id, date, results, current in entries:
        when = parse_date(date)
        if when is None or not isinstance(results, Mapping):
            continue
        for group, by_where in results.items():
            for where, result in (by_where or {}).items():
                value = result.get("value_mm") if isinstance(result, Mapping) else None
                if value is None:
                    continue
                out.setdefault(f"{group}.{where}", []).append(HistoryPoint(
                    str(record_id), when, float(value), result.get("U_mm"), current))
    for points in out.values():
        points.sort(key=lambda p: p.when)
    return out


def history_figure(points: Mapping[str, Sequence[HistoryPoint]]) -> Figure:
    """One panel per parameter: value against date, U as error bars (k = 2)."""
    names = sorted(points)
    with matplotlib.rc_context(STYLE):
        fig = Figure(figsize=(10, 1.2 + 2.0 * len(names)), layout="constrained")
        axes = fig.subplots(len(names), 1, sharex=True, squeeze=False)[:, 0]
        for ax, name in zip(axes, names, strict=True):
            for current, colour, label in ((False, BEFORE_COLOUR, "earlier calibrations"),
                                           (True, CURRENT_COLOUR, "this calibration")):
                chosen = [p for p in points[name] if p.current == current]
                if not chosen:
                    continue
                when = [p.when for p in chosen]
                value = np.array([p.value_mm for p in chosen])
                bars = np.array([np.nan if p.U_mm is None else p.U_mm for p in chosen])
                ax.errorbar(when, value, yerr=np.nan_to_num(bars), fmt="o", color=colour,
                            ecolor=colour, capsize=5, label=label if ax is axes[0] else None)
                for p in chosen:
                    if p.U_mm is None:  # said on the figure, not drawn as a zero bar
                        ax.annotate("U not evaluated", (p.when, p.value_mm), xytext=(6, 0),
                                    textcoords="offset points", va="center", fontsize=8,
                                    color="#6b7680")
            trail = points[name]
            ax.plot([p.when for p in trail], [p.value_mm for p in trail], color="#b0b7bf",
                    lw=0.8, zorder=0)
            ax.set_ylabel(f"{name} (mm)")
            ax.margins(x=0.08, y=0.25)
        axes[-1].set_xlabel("calibration date; error bars: expanded uncertainty U (k = 2)")
        fig.autofmt_xdate()
        fig.legend(*axes[0].get_legend_handles_labels(), loc="outside lower center", ncols=2,
                   frameon=False)
        fig.suptitle("This machine's calibrations over time")
    return fig
