"""The report's figures, drawn with matplotlib's Agg canvas (no display, no pyplot and
so no global figure state) and returned as PNG bytes.

Each leg keeps one colour and one marker in every figure (x vermilion circles, y green
squares, z blue triangles: the machine's red/green/blue axis colours, in a palette
that stays distinct for colour-blind readers).
"""

from __future__ import annotations

import io
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import matplotlib
import numpy as np
from matplotlib.artist import Artist
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.patches import Rectangle

from ogacq.io.declared import Finite
from ogacq.model.axis_map import AxisMap
from ogacq.model.parameters import AXES
from ogacq.model.units import UM_PER_MM
from ogacq.record.declared import Section, read
from ogacq.report.cells import Fallback
from ogacq.report.data import (
    DeviationRow,
    FitSummary,
    ModelStep,
    ParameterRow,
    ResidualSeries,
)
from ogacq.report.diagnosis_view import LegProfile
from ogacq.report.formatting import finite
from ogacq.uncertainty.reporting import headline, two_digits

if TYPE_CHECKING:
    from matplotlib.typing import RcKeyType  # read by the type checker only

LEG_COLOUR = Fallback({"x": "#D55E00", "y": "#009E73", "z": "#0072B2"}, lambda _: "black")
LEG_MARKER = {"x": "o", "y": "s", "z": "^"}
BEFORE_COLOUR = "#5d6d7e"
PREDICTED_COLOUR = "#E69F00"
MEASURED_COLOUR = "#56B4E9"
BAND_COLOUR = "#d9d9d9"
DPI = 110
STYLE: dict[RcKeyType, Any] = {"font.size": 10, "axes.titlesize": 11, "axes.labelsize": 10,
                                "figure.titlesize": 12, "legend.fontsize": 9,
                                "axes.spines.top": False, "axes.spines.right": False}


@dataclass(frozen=True)
class MapShape(Section):
    """An error map's ``extra``: a cyclic map's pitch (``ogacq.model.families.cyclic``)."""

    pitch_mm: Finite | None = None


@dataclass(frozen=True)
class FigureFile:
    name: str  # file name, e.g. "deviations.png"
    title: str
    description: str  # alt text: what the figure shows, in words
    png: bytes


def png_bytes(fig: Figure) -> bytes:
    canvas = FigureCanvasAgg(fig)
    # The layout placed once, at the resolution printed, then fixed: savefig would
    # otherwise draw the whole figure once without output only to place it (its
    # layout engine's pass), then again to print it.
    fig.set_dpi(DPI)
    engine = fig.get_layout_engine()
    if engine is not None:
        engine.execute(fig)
        fig.set_layout_engine("none")
    buffer = io.BytesIO()
    canvas.print_png(buffer)
    return buffer.getvalue()


def _band(ax: Axes, sigma_mm: float, scale: float, label: str | None) -> None:
    """The +-2 sigma gauge-noise band around zero."""
    if not finite(sigma_mm) or sigma_mm <= 0:
        return
    half = 2 * sigma_mm * scale
    ax.axhspan(-half, half, color=BAND_COLOUR, alpha=0.7, zorder=0, lw=0, label=label)
    for y in (-half, half):
        ax.axhline(y, color="#969696", lw=0.8, ls="--", zorder=0.5)


def _label_format(values: np.ndarray) -> str:
    finite_values = np.abs(values[np.isfinite(values)])
    return "{:+.2f}" if finite_values.size and finite_values.max() < 1 else "{:+.1f}"


def _not_measured(top: Axes, bottom: Axes, leg: str) -> None:
    """The panels of a leg without readings, saying so."""
    for ax, when in ((top, "before calibration"), (bottom, "after compensation")):
        ax.set_title(f"{leg} leg: {when}", color=LEG_COLOUR[leg])
        ax.text(0.5, 0.5, "not measured", transform=ax.transAxes, ha="center",
                va="center", color="#7f7f7f", fontsize=11)
        ax.set_xticks([])


def _before_panel(top: Axes, leg: str, mine: Sequence[DeviationRow]) -> None:
    """The deviations measured before calibration (mm), labelled."""
    x = np.arange(len(mine))
    before = np.array([r.before_mm for r in mine])
    bars = top.bar(x, before, 0.6, color=BEFORE_COLOUR, label="measured before calibration")
    top.bar_label(bars, labels=[f"{v:+.3f}" for v in before], padding=2, fontsize=9)
    top.axhline(0, color="black", lw=0.8)
    top.set_title(f"{leg} leg: before calibration", color=LEG_COLOUR[leg], fontweight="bold")


def _after_panel(bottom: Axes, leg: str, mine: Sequence[DeviationRow], validated: bool) -> None:
    """What remains after compensation (µm): predicted, and measured when validated,
    against each deviation's noise band (its own averaging)."""
    x = np.arange(len(mine))
    bottom.set_title(f"{leg} leg: after compensation", color=LEG_COLOUR[leg])
    width = 0.38 if validated else 0.6
    offset = width / 2 if validated else 0.0
    for k, r in enumerate(mine):
        half = 2 * r.noise_mm * UM_PER_MM
        bottom.bar(k, 2 * half, 0.9, bottom=-half, color=BAND_COLOUR, zorder=0,
                   label="gauge noise ±2σ" if k == 0 else None)
    predicted = np.array([r.after_predicted_mm for r in mine]) * UM_PER_MM
    bars = bottom.bar(x - offset, predicted, width, color=PREDICTED_COLOUR,
                      label="after compensation, predicted")
    fmt = _label_format(predicted)
    bottom.bar_label(bars, labels=[fmt.format(v) for v in predicted], padding=2, fontsize=8.5)
    if validated:
        measured = np.array([np.nan if r.after_measured_mm is None
                             else r.after_measured_mm for r in mine]) * UM_PER_MM
        bars = bottom.bar(x + offset, measured, width, color=MEASURED_COLOUR,
                          label="after write-back, measured")
        fmt = _label_format(measured)
        bottom.bar_label(bars, labels=["" if np.isnan(v) else fmt.format(v)
                                       for v in measured], padding=2, fontsize=8.5)
    bottom.axhline(0, color="black", lw=0.8)


def _legend_of_all(fig: Figure, axes: np.ndarray) -> None:
    """One legend under the panels, clear of the bars: each label once."""
    legend: dict[str, Artist] = {}
    for ax in axes.ravel():
        for handle, label in zip(*ax.get_legend_handles_labels(), strict=True):
            legend.setdefault(label, handle)
    fig.legend(list(legend.values()), list(legend), loc="outside lower center",
               ncols=len(legend), frameon=False)


def deviations_figure(rows: Sequence[DeviationRow], legs: Sequence[str] = AXES) -> Figure:
    """Top: the measured deviations per leg and posture (mm). Bottom: what remains after
    compensation (µm), predicted from the fit and, when given, measured in a validation
    campaign, against the gauge-noise band. A leg of ``legs`` without readings gets an
    empty panel that says so."""
    legs = list(dict.fromkeys([*legs, *(r.leg for r in rows)]))
    validated = any(r.after_measured_mm is not None for r in rows)
    with matplotlib.rc_context(STYLE):
        fig = Figure(figsize=(3.6 * len(legs) + 0.8, 7.8), layout="constrained")
        axes = fig.subplots(2, len(legs), sharey="row", squeeze=False)
        for col, leg in enumerate(legs):
            mine = [r for r in rows if r.leg == leg]
            top, bottom = axes[0, col], axes[1, col]
            if not mine:
                _not_measured(top, bottom, leg)
                continue
            _before_panel(top, leg, mine)
            _after_panel(bottom, leg, mine, validated)
            ticks = [f"{r.posture.capitalize()}\nalong {r.gauge_axis}\n({r.name})" for r in mine]
            top.set_xticks(np.arange(len(mine)), ticks, fontsize=8.5)
            bottom.set_xticks(np.arange(len(mine)), ticks, fontsize=8.5)
        axes[0, 0].set_ylabel("deviation before (mm)")
        axes[1, 0].set_ylabel("deviation after (µm)")
        _headroom(axes[0, 0])
        _symmetric(axes[1, 0], 1.25)
        _legend_of_all(fig, axes)
        fig.suptitle("Deviations per leg and posture, relative to Zero (averaged over cycles)")
    return fig


def _headroom(ax: Axes) -> None:
    """Room above and below the bars for their value labels."""
    low, high = ax.get_ylim()
    span = high - low
    ax.set_ylim(low - 0.08 * span if low < 0 else low, high + 0.08 * span if high > 0 else high)


def _symmetric(ax: Axes, factor: float) -> None:
    low, high = ax.get_ylim()
    bound = max(abs(low), abs(high)) * factor
    ax.set_ylim(-bound, bound)


def _scatter_by_leg(ax: Axes, series: ResidualSeries, label: bool) -> None:
    """Colour and marker by leg; of each leg's two gauges the first filled, the second
    hollow, so that a pattern on one gauge shows."""
    gauges = np.array(series.gauge)
    legs = np.array(series.leg)
    y = series.residual_mm * UM_PER_MM
    for leg in AXES:
        for k, gauge in enumerate(sorted(set(gauges[legs == leg]))):
            sel = (legs == leg) & (gauges == gauge)
            colour = LEG_COLOUR[leg]
            ax.scatter(series.number[sel], y[sel], s=26, marker=LEG_MARKER[leg], zorder=3,
                       facecolors=colour if k == 0 else "white", edgecolors=colour,
                       linewidths=1.2, label=f"gauge {gauge} ({leg} leg)" if label else None)


def _legend_below(fig: Figure, ax: Axes) -> None:
    """The band in the first column, then one column per leg (two gauges each)."""
    handles, labels = ax.get_legend_handles_labels()
    if labels and "noise" in labels[0] and len(labels) % 2 == 1:
        handles.insert(1, Rectangle((0, 0), 0, 0, visible=False))
        labels.insert(1, "")
    fig.legend(handles, labels, loc="outside lower center", ncols=max(1, len(labels) // 2),
               frameon=False)


def _leg_spans(ax: Axes, series: ResidualSeries, names: bool = True) -> None:
    """Where each leg's test begins and ends, in reading numbers."""
    legs = list(series.leg)
    start = 0
    for k in range(1, len(legs) + 1):
        if k == len(legs) or legs[k] != legs[start]:
            if k < len(legs):
                ax.axvline(series.number[k] - 0.5, color="#bdbdbd", lw=0.8, zorder=0.5)
            if names:
                ax.text((series.number[start] + series.number[k - 1]) / 2, 1.0,
                        f"{legs[start]} leg", transform=ax.get_xaxis_transform(),
                        ha="center", va="bottom", fontsize=9,
                        color=LEG_COLOUR[legs[start]])
            start = k


def _residual_limits(ax: Axes, values_um: np.ndarray, sigma_mm: float) -> None:
    bound = max(float(np.nanmax(np.abs(values_um))) if len(values_um) else 0.0,
                3 * sigma_mm * UM_PER_MM if finite(sigma_mm) else 0.0, 1e-3)
    ax.set_ylim(-1.15 * bound, 1.15 * bound)


def residuals_figure(series: ResidualSeries, noise_mm: float, rms_mm: float) -> Figure:
    with matplotlib.rc_context(STYLE):
        fig = Figure(figsize=(10, 4.8), layout="constrained")
        ax = fig.subplots()
        _band(ax, noise_mm, UM_PER_MM, f"gauge noise ±2σ (σ = {noise_mm * UM_PER_MM:.2f} µm)")
        ax.axhline(0, color="black", lw=0.8)
        _scatter_by_leg(ax, series, label=True)
        _leg_spans(ax, series)
        _residual_limits(ax, series.residual_mm * UM_PER_MM, noise_mm)
        ax.set_xlim(0.5, series.number[-1] + 0.5)
        ax.set_xlabel("reading number, in the order taken")
        ax.set_ylabel("residual (µm)")
        ax.set_title(f"Residuals of the joint-offset model: rms {rms_mm * UM_PER_MM:.2f} µm, "
                     f"gauge noise σ {noise_mm * UM_PER_MM:.2f} µm", pad=18)
        _legend_below(fig, ax)
    return fig


@dataclass(frozen=True)
class _Whiskers:
    """One fit's values and whiskers, a row per parameter name: U where the record's
    budget gives it, else 2 std of the fit (``fallback``), NaN where not determined."""

    rows: tuple[ParameterRow | None, ...]
    value: np.ndarray
    half: np.ndarray
    texts: tuple[str, ...]  # each value as its headline says it
    fallback: bool

    @classmethod
    def of(cls, summary: FitSummary, names: Sequence[str],
           given: Mapping[str, float | None] | None) -> _Whiskers:
        rows = tuple(summary.row(n) for n in names)
        expanded = dict.fromkeys(names) | dict(given or {})  # None: U not evaluated
        value = np.array([r.value if r and finite(r.std) else np.nan for r in rows])
        half = np.full(len(rows), np.nan)
        texts = []
        fallback = False
        for k, r in enumerate(rows):
            if r is None or not finite(r.std):
                texts.append("not determined by these readings")
                continue
            U = expanded[r.name]
            if U is None:
                fallback = True
                half[k] = 2 * r.std
                texts.append(f"{headline(r.value, None, None, r.unit).value} ± "
                             f"{two_digits(2 * r.std)} {r.unit} (2 std, U not evaluated)")
            else:
                half[k] = U
                texts.append(str(headline(r.value, U, 2.0, r.unit)))
        return cls(rows, value, half, tuple(texts), fallback)


@dataclass(frozen=True)
class _Series:
    label: str
    whiskers: _Whiskers
    shift: float  # of its bars from the name's line
    colour: str


def _draw_series(left: Axes, right: Axes, y: np.ndarray, s: _Series, height: float) -> None:
    """Values with whiskers on the left, U on the right, each labelled."""
    w = s.whiskers
    left.barh(y + s.shift, w.value, height, color=s.colour, label=s.label,
              xerr=np.nan_to_num(w.half), ecolor="black", capsize=5)
    bars = right.barh(y + s.shift, w.half * UM_PER_MM, height, color=s.colour)
    right.bar_label(bars, labels=["" if np.isnan(v) else f"{two_digits(v)} µm"
                                  for v in w.half * UM_PER_MM], padding=3, fontsize=9)
    for k, r in enumerate(w.rows):
        if r is None:
            continue
        # on the far side of zero, clear of the bar, its whisker and the names
        left.annotate(w.texts[k], (0, y[k] + s.shift), xytext=(-6 if r.value >= 0 else 6, 0),
                      textcoords="offset points", va="center", fontsize=9,
                      ha="right" if r.value >= 0 else "left")
        if not finite(r.std):
            right.annotate("not determined", (0, y[k] + s.shift), xytext=(4, 0),
                           textcoords="offset points", va="center", color="#b22222")


def _label_parameters(left: Axes, right: Axes, y: np.ndarray, names: Sequence[str],
                      fallback: bool) -> None:
    whiskers = "expanded uncertainty U (k = 2)" + (
        "; 2 std where U was not evaluated" if fallback else "")
    left.axvline(0, color="black", lw=0.8)
    left.set_yticks(y, names)
    bound = max(abs(v) for v in left.get_xlim())
    left.set_xlim(-1.1 * bound, 1.1 * bound)  # symmetric: room for the labels
    left.set_xlabel(f"value (mm), whiskers: {whiskers}")
    left.set_title("Identified joint offsets")
    right.set_yticks(y, [])
    right.set_xlim(0, right.get_xlim()[1] * 1.3)  # room for the labels
    right.set_xlabel("U, k = 2 (µm)" + (" or 2 std" if fallback else ""))
    right.set_title("How precisely each is known")


def parameters_figure(fit: FitSummary, validation: FitSummary | None = None,
                      expanded: Mapping[str, float | None] | None = None,
                      validation_expanded: Mapping[str, float | None] | None = None,
                      ) -> Figure:
    """Left: each identified value with its expanded uncertainty U (k = 2, the record's
    budget) as whiskers, labelled as every headline is (JCGM 100:2008 7.2.6). Right: U
    itself, how precisely each is known. ``expanded``/``validation_expanded``: U by
    parameter name; where a U was not evaluated, the whiskers are 2 std of the fit
    alone and say so."""
    names = [p.name for p in fit.parameters]
    y = np.arange(len(names))[::-1].astype(float)
    identified = _Whiskers.of(fit, names, expanded)
    series = [_Series("identified", identified, 0.0, BEFORE_COLOUR)]
    if validation is not None:
        series = [_Series("identified", identified, 0.18, BEFORE_COLOUR),
                  _Series("remaining after write-back (validation)",
                          _Whiskers.of(validation, names, validation_expanded), -0.18,
                          MEASURED_COLOUR)]
    with matplotlib.rc_context(STYLE):
        fig = Figure(figsize=(10, 1.0 + 0.75 * len(names) * (1.5 if validation else 1)),
                     layout="constrained")
        left, right = fig.subplots(1, 2, width_ratios=(1.6, 1))
        for s in series:
            _draw_series(left, right, y, s, 0.32 if validation else 0.5)
        _label_parameters(left, right, y, names, any(s.whiskers.fallback for s in series))
        if validation is not None:
            fig.legend(*left.get_legend_handles_labels(), loc="outside lower center",
                       ncols=2, frameon=False)
    return fig


def diagnosis_figure(steps: Sequence[ModelStep], noise_mm: float) -> Figure:
    """Residuals of the joint-offset model, then with each effect of the diagnosis added,
    on one scale: what each effect explains."""
    with matplotlib.rc_context(STYLE):
        fig = Figure(figsize=(10, 1.6 + 2.3 * len(steps)), layout="constrained")
        axes = fig.subplots(len(steps), 1, sharex=True, sharey=True, squeeze=False)[:, 0]
        everything = np.concatenate([s.residuals.residual_mm for s in steps]) * UM_PER_MM
        for k, (ax, step) in enumerate(zip(axes, steps, strict=True)):
            _band(ax, noise_mm, UM_PER_MM, "gauge noise ±2σ" if k == 0 else None)
            ax.axhline(0, color="black", lw=0.8)
            _scatter_by_leg(ax, step.residuals, label=k == 0)
            _leg_spans(ax, step.residuals, names=k == 0)
            ax.set_title(f"{step.label}: rms {step.rms_mm * UM_PER_MM:.2f} µm", loc="left",
                         pad=16 if k == 0 else 6)
            ax.set_ylabel("residual (µm)")
        _residual_limits(axes[0], everything, noise_mm)
        axes[-1].set_xlabel("reading number, in the order taken")
        axes[-1].set_xlim(0.5, steps[0].residuals.number[-1] + 0.5)
        _legend_below(fig, axes[0])
        fig.suptitle("Residuals before and after each effect the diagnosis found")
    return fig


def maps_figure(maps: Sequence[AxisMap]) -> Figure:
    """Each actuator's error map (actual minus commanded joint position) along its
    joint coordinate, forward and reverse, with a band of two standard
    uncertainties (k = 2); a map with a cyclic part is drawn whole and over two of
    its periods, where its shape shows."""
    with matplotlib.rc_context(STYLE):
        rows = len(maps)
        fig = Figure(figsize=(10, 0.8 + 2.6 * rows), layout="constrained")
        axes = fig.subplots(rows, 2, squeeze=False, width_ratios=(3, 2))
        for (whole, detail), m in zip(axes, maps, strict=True):
            q = np.array(m.positions_mm)
            fwd, rev = np.array(m.forward_mm), np.array(m.reverse_mm)
            u_f, u_r = np.array(m.u_forward_mm), np.array(m.u_reverse_mm)
            colour = LEG_COLOUR[m.axis]
            pitch = read(MapShape, m.extra, f"maps.{m.axis}.extra").pitch_mm
            lo = m.reference_mm if pitch and q[0] <= m.reference_mm <= q[-1] - 2 * pitch \
                else q[0]
            span = 2 * pitch if pitch else (q[-1] - q[0]) / 4
            sides = [(fwd, u_f, colour, "forward", "-")]
            if not np.allclose(fwd, rev):
                sides.append((rev, u_r, BEFORE_COLOUR, "reverse", "--"))
            for ax, mask in ((whole, np.ones(len(q), dtype=bool)),
                             (detail, (q >= lo) & (q <= lo + span))):
                for values, u, tint, side, style in sides:
                    ax.fill_between(q[mask], (values - 2 * u)[mask] * UM_PER_MM,
                                    (values + 2 * u)[mask] * UM_PER_MM, color=tint, alpha=0.2,
                                    lw=0, label=f"{side} ±2u")
                    ax.plot(q[mask], values[mask] * UM_PER_MM, color=tint, lw=1.2, ls=style,
                            label=side)
                ax.axhline(0, color="black", lw=0.6)
                ax.set_xlabel(f"q{m.axis} (mm)")
            whole.set_ylabel("actual − commanded (µm)")
            whole.set_title(f"{m.axis} axis: {m.source}", loc="left")
            detail.set_title(f"{lo:+.1f} to {lo + span:+.1f} mm", loc="left")
            whole.legend(loc="best", frameon=False)
        fig.suptitle("Error map of each actuator (the compensation table's values)")
    return fig


def profiles_figure(profiles: Sequence[LegProfile], noise_mm: float) -> Figure:
    """Residuals along each scanned leg's joint coordinate, each gauge's mean per
    position, with the joint offsets only and with the effects found."""
    with matplotlib.rc_context(STYLE):
        rows = len(profiles)
        fig = Figure(figsize=(10, 0.8 + 2.4 * rows), layout="constrained")
        axes = fig.subplots(rows, 2, squeeze=False, sharey=True)
        for (before, after), p in zip(axes, profiles, strict=True):
            q = np.array(p.q_mm, dtype=float)  # an empty bin (null) as NaN
            for ax, series, title in (
                    (before, {g: v.before_um for g, v in p.gauges.items()}, "joint offsets only"),
                    (after, {g: v.after_um for g, v in p.gauges.items()},
                     "with the effects found")):
                _band(ax, noise_mm, UM_PER_MM, "gauge noise ±2σ")
                for gauge, values in series.items():
                    ax.plot(q, np.array(values, dtype=float), lw=0.9, marker=".", ms=2,
                            color=LEG_COLOUR[gauge.split("_")[0]],
                            alpha=0.85, label=f"gauge {gauge}")
                ax.axhline(0, color="black", lw=0.6)
                ax.set_title(f"{p.leg} leg: {title}", loc="left")
                ax.set_xlabel(f"q{p.leg} (mm)")
            before.set_ylabel("mean residual (µm)")
            after.legend(loc="best", frameon=False, fontsize=8)
        fig.suptitle("Residuals along each scanned leg, before and after")
    return fig
