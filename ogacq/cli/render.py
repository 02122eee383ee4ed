"""Terminal rendering: the only place that imports rich."""

from __future__ import annotations

import numpy as np
from rich.console import Console
from rich.table import Table

from ogacq.identify.fit import FitResult
from ogacq.model.parameters import effect_of

console = Console()


def _num(value: float, digits: int = 4, sign: bool = True) -> str:
    if value is None or not np.isfinite(value):
        return "-"
    return f"{value:+.{digits}f}" if sign else f"{value:.{digits}f}"


def print_fit(result: FitResult, params_label: str) -> None:
    obs = result.observations
    ident = result.identifiability
    console.print(f"[bold]{obs.source or 'data'}[/]: {len(obs)} {obs.kind}, "
                  f"parameters [bold]{params_label}[/], {result.method} fit, "
                  f"{result.weighting.upper()}")
    table = Table(show_edge=False, header_style="bold")
    table.add_column("parameter")
    table.add_column("value", justify="right")
    table.add_column("std (gauge noise)", justify="right")
    table.add_column("std (from residuals)", justify="right")
    table.add_column("unit")
    scale = result.sigma_mm / result.noise.sigma_mm if np.isfinite(result.sigma_mm) else np.nan
    if not obs.raw:
        scale /= np.sqrt(2.0)  # a deviation is a difference of two readings
    for name, value, std in zip(result.names, result.values, result.std, strict=True):
        table.add_row(name, _num(value), _num(std, sign=False), _num(std * scale, sign=False),
                      effect_of(name).unit)
    console.print(table)
    console.print(f"residual rms {result.residual_rms_mm:.4f} mm, sigma from residuals "
                  f"{_num(result.sigma_mm)} mm ({result.dof} dof); gauge noise "
                  f"{result.noise.describe()}")
    console.print(f"condition number {ident.condition_number:.4g}, rank {ident.rank} of "
                  f"{len(result.names)}")
    if ident.identifiable:
        console.print("[green]identifiable[/]: every parameter is determined by these data")
    else:
        console.print("[red]not identifiable[/]:")
        for reason in ident.reasons:
            console.print(f"  - {reason}")
    for a, b, c in ident.correlated_pairs:
        console.print(f"  correlated: {a} / {b} {c:+.4f}")
    if np.isfinite(scale) and scale > 3:
        console.print(f"[yellow]the residuals are {scale:.0f}x the gauge noise: the model "
                      "leaves something out; run `ogacq diagnose` on the readings[/]")


def print_plan(pred, machine_name: str, postures: str, cycles: int) -> None:
    console.print(f"[bold]{machine_name}[/]: postures {postures}, {cycles} cycles per leg, "
                  f"{pred.n_readings} readings, gauge noise {pred.noise_mm:g} mm")
    table = Table(show_edge=False, header_style="bold")
    table.add_column("parameter")
    table.add_column("std analytic", justify="right")
    if pred.mc_std is not None:
        table.add_column(f"std Monte-Carlo ({pred.trials} fits)", justify="right")
        table.add_column("bias", justify="right")
    table.add_column("unit")
    for k, name in enumerate(pred.names):
        row = [name, f"{pred.analytic_std[k]:.4f}"]
        if pred.mc_std is not None:
            row += [f"{pred.mc_std[k]:.4f}", f"{pred.mc_bias[k]:+.4f}"]
        table.add_row(*row, effect_of(name).unit)
    console.print(table)
    ident = pred.identifiability
    if ident.identifiable:
        console.print(f"[green]identifiable[/] (condition number {ident.condition_number:.3g})")
    else:
        console.print("[red]not identifiable[/] with this plan:")
        for reason in ident.reasons:
            console.print(f"  - {reason}")
    if pred.mc_std is not None:
        console.print(f"Monte-Carlo: {pred.converged_fraction:.1%} of fits converged, "
                      f"{pred.mc_seconds:.2f} s")
