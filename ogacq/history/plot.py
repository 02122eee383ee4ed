"""Each parameter of a machine over time, with its U as error bars, the write-backs
between calibrations (the value as found, then as left) and the flagged drifts
marked from the state as left: one panel per parameter, drawn on matplotlib's Agg
canvas (no display needed)."""

from __future__ import annotations

import io
from collections.abc import Mapping, Sequence
from datetime import datetime
from pathlib import Path

from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from ogacq.history.drift import Drift, expanded
from ogacq.history.store import Calibration
from ogacq.io.atomic import write_atomically

DPI = 110


def _when(date: str | None) -> datetime | None:
    """The calibration's date as the wall time it was stated in (a time zone dropped:
    the dates of one machine are compared on one axis)."""
    if not date:
        return None
    try:
        return datetime.fromisoformat(date.replace("Z", "+00:00")).replace(tzinfo=None)
    except ValueError:
        return None


def history_figure(title: str, calibrations: Sequence[Calibration], drifts: Sequence[Drift],
                   written: Mapping[str, Mapping[str, float]] | None = None) -> Figure:
    names = list(dict.fromkeys(n for c in calibrations for n in c.parameters))
    fig = Figure(figsize=(7.5, 1.2 + 2.0 * max(len(names), 1)), layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(max(len(names), 1), 1, sharex=True, squeeze=False)[:, 0]
    dated = [(c, _when(c.date)) for c in calibrations]
    by_date = all(when is not None for _, when in dated)
    fig.suptitle(title, fontsize=11)
    for ax, name in zip(axes, names, strict=False):
        xs, ys, errs, guessed = [], [], [], []
        for index, (c, when) in enumerate(dated):
            p = c.parameters.get(name)
            if p is None:
                continue
            u, basis = expanded(p)
            xs.append(when if by_date else index + 1)
            ys.append(p.value_mm * 1000)
            errs.append((u or 0.0) * 1000)
            guessed.append(basis != "U")
        ax.errorbar(xs, ys, yerr=errs, fmt="o-", color="#1f5fa8", ecolor="#6b8fc4",
                    capsize=4, lw=1.2, ms=5, label="value ± U")
        if any(guessed):
            ax.plot([x for x, g in zip(xs, guessed, strict=True) if g],
                    [y for y, g in zip(ys, guessed, strict=True) if g], "o", mfc="white",
                    mec="#1f5fa8", ms=5, zorder=5, label="U unknown: ± 2 std")
        where = {c.record_id: x for (c, _), x in zip(dated, range(len(dated)), strict=True)}
        for index, (c, when) in enumerate(dated):
            wrote = (written or {}).get(c.record_id, {}).get(name)
            p = c.parameters.get(name)
            if wrote is None or p is None or index == len(dated) - 1:
                continue
            x = when if by_date else index + 1
            ax.plot([x, x], [p.value_mm * 1000, (p.value_mm + wrote) * 1000], "--",
                    color="#2e8b57", lw=1.5, zorder=3)
            ax.plot([x], [(p.value_mm + wrote) * 1000], "^", color="#2e8b57", ms=7, zorder=5,
                    label="as left by a write-back")
        for d in drifts:
            if d.parameter != name or not d.flagged:
                continue
            i, j = where[d.from_record], where[d.to_record]
            x0 = dated[i][1] if by_date else i + 1
            x1 = dated[j][1] if by_date else j + 1
            y0 = (calibrations[i].parameters[name].value_mm + d.written_mm) * 1000
            y1 = calibrations[j].parameters[name].value_mm * 1000
            ax.plot([x0, x1], [y0, y1], "-", color="#c0392b", lw=2.5, zorder=4,
                    label="change > U of the change")
        ax.set_ylabel(f"{name}\n(µm)", fontsize=9)
        ax.grid(True, alpha=0.3)
        handles, labels = ax.get_legend_handles_labels()
        unique = dict(zip(labels, handles, strict=True))
        ax.legend(unique.values(), unique.keys(), fontsize=8, loc="best")
    axes[-1].set_xlabel("calibration date" if by_date else "calibration")
    if by_date:
        fig.autofmt_xdate()
    return fig


def write_history_plot(path: Path, title: str, calibrations: Sequence[Calibration],
                       drifts: Sequence[Drift],
                       written: Mapping[str, Mapping[str, float]] | None = None) -> Path:
    buffer = io.BytesIO()  # drawn whole, then written whole (a full disk leaves no half PNG)
    history_figure(title, calibrations, drifts, written).savefig(buffer, format="png",
                                                                 dpi=DPI)
    write_atomically(path, buffer.getvalue())
    return path
