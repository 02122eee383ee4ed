"""refit's account of a fit (and the notes every analysis prints first)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ogacq.cli.plain import Printer, shown, table_of
from ogacq.cli.verdict_text import paragraph
from ogacq.model.parameters import effect_of

out = Printer()

if TYPE_CHECKING:
    from ogacq.identify.fit import FitResult


def format_number(value: float | None, digits: int = 4, sign: bool = True) -> str:
    if not isinstance(value, int | float | np.floating) or isinstance(value, bool) or \
            not np.isfinite(value):
        return "-"
    return f"{value:+.{digits}f}" if sign else f"{value:.{digits}f}"


def print_notes(notes: list[str]) -> None:
    """What an analysis says first about the session it read: partial, edited."""
    for note in notes:
        out.print(f"[yellow]{shown(note)}[/]")


def print_fit(result: FitResult, params_label: str, diagnose: str = "ogacq diagnose") -> None:
    """``diagnose``: the command that diagnoses these readings, naming their file."""
    obs = result.observations
    ident = result.identifiability
    out.print(f"[bold]{shown(obs.source or 'data')}[/]: {len(obs)} {obs.kind}, "
              f"parameters [bold]{params_label}[/], {result.method} fit, "
              f"{result.weighting.upper()}")
    table = table_of("parameter", ">value", ">std (gauge noise)", ">std (from residuals)",
                     "unit")
    scale = result.sigma_mm / result.noise.sigma_mm if np.isfinite(result.sigma_mm) else np.nan
    if not obs.raw:
        scale /= np.sqrt(2.0)  # a deviation is a difference of two readings
    for name, value, std in zip(result.names, result.values, result.std, strict=True):
        table.add_row(name, format_number(value), format_number(std, sign=False),
                      format_number(std * scale, sign=False), effect_of(name).unit)
    out.print(table)
    out.print(f"residual rms {result.residual_rms_mm:.4f} mm, sigma from residuals "
              f"{format_number(result.sigma_mm, sign=False)} mm ({result.dof} dof); gauge noise "
              f"{result.noise.describe()}")
    out.print(f"condition number {ident.condition_number:.4g}, rank {ident.rank} of "
              f"{len(result.names)}")
    if ident.identifiable:
        out.print("[green]identifiable[/]: every parameter is determined by these data")
    else:
        out.print("[red]not identifiable[/]:")
        for reason in ident.reasons:
            out.print(f"  - {shown(reason)}")
    for a, b, c in ident.correlated_pairs:
        out.print(f"  correlated: {a} / {b} {c:+.4f}")

    # scipy.stats (a second of start-up) loads here: `refit --json` never needs it
    from ogacq.identify.consistency import fit_verdict

    verdict = fit_verdict(result)
    colour = {"consistent": "green", "inconsistent": "red"}.get(verdict.state, "yellow")
    out.print(f"fit: [{colour}]{paragraph(verdict)}[/]")
    if verdict.state == "inconsistent":
        out.print(f"[yellow]the model leaves something out: next, {shown(diagnose)}[/]")
