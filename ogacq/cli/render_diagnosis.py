"""Terminal account of a diagnosis (``ogacq diagnose`` without ``--json``)."""

from __future__ import annotations

import numpy as np
from rich.table import Table

from ogacq.cli.plain import Printer, shown, table_of
from ogacq.cli.render_maps import (
    print_axis_map,
    print_coverage,
    print_map_effect,
    print_profiles,
    print_proposals,
)
from ogacq.cli.verdict_text import paragraph
from ogacq.diagnose.diagnosis import Diagnosis, EffectFound
from ogacq.diagnose.library import BASE_MODEL, label, unit
from ogacq.diagnose.locate import Location, row_labels
from ogacq.diagnose.maps import MapEffect
from ogacq.identify.consistency import LEVEL, Verdict, format_p
from ogacq.model.parameters import PARAM_INDEX
from ogacq.model.units import UM_PER_MM
from ogacq.uncertainty.reporting import measure

out = Printer()

MANY_GROUPS = 12  # beyond this many postures (a scan) only the worst are listed
SHOWN_GROUPS = 5


def _judged(title: str, v: Verdict) -> str:
    colour = "green" if v.consistent else "red"
    return f"{title}: [{colour}]{paragraph(v)}[/]"


def print_diagnosis(d: Diagnosis, machine_file: str = "M.toml") -> None:
    out.print(f"[bold]{shown(d.source or 'data')}[/]: {d.n_observations} {d.kind}; gauge noise "
              f"{d.noise.describe()}")
    out.print(_judged("joint offsets only", d.selection.base.verdict))
    _print_outliers(d)
    if d.outcome == "consistent":
        out.print("The joint-offset model reproduces these recordings within the gauge "
                  "noise: nothing is left to explain.")
        if d.mapped is not None and d.mapped.search.searched:
            out.print(f"Nor along any axis or in time (searched at the "
                      f"{d.mapped.search.level:g} level): "
                      + "; ".join(c.describe() for c in d.mapped.search.coverage))
        _print_offsets(d)
        return
    if d.outcome == "undetermined":
        out.print("These recordings leave nothing to judge the fit by: nothing is "
                  "diagnosed.")
        _print_offsets(d)
        return
    out.print()
    _print_location("Where the misfit of the joint-offset model sits", d.located)
    _print_capability(d)
    _print_search(d)
    print_coverage(d)
    _print_outcome(d, machine_file)
    print_profiles(d)
    print_proposals(d, machine_file)
    _print_offsets(d)
    for caveat in d.caveats():
        out.print(f"[yellow]note[/]: {shown(caveat)}")


def print_next(d: Diagnosis, session: str, *, controller_gone: bool = False) -> None:
    """What to do with a session after its diagnosis, naming it: the write-back of the
    model that explains it, or what must come first. ``controller_gone``: the session
    ran on the built-in simulator, which stopped with its command."""
    if controller_gone and d.outcome in ("consistent", "explained"):
        step = ("a rehearsal: its simulated controller stopped with the command that ran "
                "it, so nothing is written from it (`ogacq calibrate --simulator` "
                "rehearses the write-back)")
    elif d.outliers is not None and d.outliers.readings:
        step = ("check the gauges of the readings named above, then run the campaign "
                "again: nothing is written from readings a knock may have moved")
    elif d.outcome == "consistent":
        step = (f"ogacq offsets write {session}   (the joint offsets, shown and confirmed "
                "first)")
    elif d.outcome == "explained":
        step = (f"ogacq offsets write {session} --from-diagnosis   (the joint offsets of "
                "this model; the effects beside them stay until corrected)")
    elif d.outcome == "undetermined":
        return
    else:
        step = ("the measurement proposed above: nothing explains these readings well "
                "enough to write offsets from them")
    out.print(f"next: {shown(step)}")


def _print_outliers(d: Diagnosis) -> None:
    """Readings far from their repeats: said before any physics, which they are not."""
    if d.outliers is None:
        return
    found = d.outliers.readings
    one = len(found) == 1
    out.print(f"[yellow]{'One reading lies' if one else f'{len(found)} readings lie'} far "
              f"from {'its' if one else 'their'} repeats, which agree among themselves[/] "
              "(a value misread or typed wrong, or the gauge knocked between cycles?):")
    for r in found:
        out.print(f"  {shown(r.describe())} (p = {format_p(r.p_value)} over "
                  f"{d.outliers.tested} readings tested)")
    out.print(_judged(f"  without {'it' if one else 'them'}, joint offsets only",
                      d.outliers.verdict_without))
    out.print(f"  check {'it' if one else 'them'}, or measure that posture again; the rest "
              "of this diagnosis keeps every reading")


def _print_location(title: str, loc: Location) -> None:
    out.print(f"[bold]{title}[/] (share of the misfit; under noise alone each would "
              "carry the share in brackets)")
    for level in ("gauge", "leg", "posture", "cycle", "approach"):
        groups = loc.level(level)
        if not groups:
            continue
        if len(groups) > MANY_GROUPS:  # a scan: the profile along q says where
            top = sorted(groups, key=lambda g: -g.excess)[:SHOWN_GROUPS]
            cells = (f"{len(groups)} groups, most beyond their noise share: "
                     + ", ".join(f"{g.key} {g.share:.1%} ({g.expected_share:.1%})"
                                 for g in top))
        else:
            cells = ", ".join(f"{g.key} {g.share:.0%} ({g.expected_share:.0%})"
                              for g in groups)
        name = "approach (sides of the x, y, z drives)" if level == "approach" else level
        out.print(f"  {name}: {shown(cells)}")
    trends = [t for t in loc.trends if t.p_value < LEVEL]
    for t in trends:
        out.print(f"  trend with time on gauge {t.gauge}: "
                  f"{t.slope_mm_per_h * UM_PER_MM:+.1f} ± "
                  f"{t.std_mm_per_h * UM_PER_MM:.1f} µm/h (p = {format_p(t.p_value)})")
    if loc.trends and not trends:
        out.print("  no gauge's residuals trend with time")
    # each difference is one of many looked at (hundreds on a scan): corrected for them
    looked = max(len(loc.approach), 1)
    diffs = sorted((a for a in loc.approach if a.p_value * looked < LEVEL),
                   key=lambda a: a.p_value)
    for a in diffs[:SHOWN_GROUPS]:
        out.print(f"  approach sides {a.sides[0]} vs {a.sides[1]} on gauge {a.gauge} at "
                  f"{shown(a.posture)}: {a.difference_mm * UM_PER_MM:+.1f} ± "
                  f"{a.std_mm * UM_PER_MM:.1f} µm "
                  f"(p = {format_p(min(1.0, a.p_value * looked))} over {looked})")
    if len(diffs) > SHOWN_GROUPS:
        out.print(f"  and {len(diffs) - SHOWN_GROUPS} more differences between approach "
                  "sides")
    if not loc.approach:
        out.print("  no posture was read from both approach sides")
    elif not diffs:
        out.print("  no difference between approach sides (corrected for the "
                  f"{looked} compared)")
    out.print()


def _print_capability(d: Diagnosis) -> None:
    cap = d.capability
    out.print(f"[bold]What these data can tell beside the joint offsets[/] "
              f"({cap.n_data} independent {d.kind}, {cap.dof_after_offsets} left after the "
              f"offsets, {cap.effect_rank} independent effect directions)")
    table = table_of("effect", ">std", ">shows from", "unit", ">offsets absorb", "aliases",
                     fold=True, pad_edge=False)
    for name, v in cap.visibility.items():
        if not v.visible:
            table.add_row(name, "-", "[red]not seen[/]", v.unit, "-", "")
            continue
        shows = f"{v.detectable:.3g}" if v.identifiable else f"[yellow]{v.detectable:.3g}[/]"
        table.add_row(name, f"{v.std:.3g}", shows, v.unit, f"{v.absorbed:.0%}",
                      ", ".join(a for a, _ in v.aliases))
    out.print(table)
    if cap.invisible():
        out.print(f"  not seen at all: {', '.join(cap.invisible())}"
                  + (" (tabulated deviations carry no approach side and no time)"
                         if d.kind == "deviations" else ""))
    if cap.weak():
        out.print(f"  seen only above their plausible range: {', '.join(cap.weak())}")
    for group in cap.alias_groups():
        out.print(f"  cannot be told apart: {', '.join(group)}")
    if cap.saturated:
        out.print(f"  [yellow]{cap.dof_after_offsets} observations are left after the "
                  f"offsets and the effects span {cap.effect_rank} directions: any "
                  f"{cap.dof_after_offsets} independent effects reproduce these data exactly, "
                  "so the data cannot choose among such sets[/]")
    for option, plan in d.plans:
        groups = plan.alias_groups()
        out.print(f"  with '{option.key}' ({option.description}): "
                  f"{plan.dof_after_offsets} dof after the offsets, "
                  f"{plan.effect_rank} effect directions, "
                  f"{len(plan.invisible())} effects unseen, "
                  f"{len(groups)} alias groups")
    out.print()


def _print_search(d: Diagnosis) -> None:
    sel = d.selection
    out.print(f"[bold]Search[/]: {sel.candidates_fitted} candidate models fitted "
              "(every effect alone and in pairs, at each step)")
    if not sel.steps:
        out.print("  no effect or pair of effects improves the fit significantly with "
                  "plausible values")
    rows = [(str(k), step.label, f"{step.before.verdict.rms_mm * UM_PER_MM:.2f} µm",
             f"{step.after.verdict.rms_mm * UM_PER_MM:.2f} µm",
             f"{step.before.verdict.chi2_dof:.3g} → {step.after.verdict.chi2_dof:.3g}",
             format_p(step.p_value), f"{step.delta_bic:+.1f}")
            for k, step in enumerate(sel.steps, 1)]
    # each cell whole on its line, the effects added wrapping between names (folded to
    # narrow columns at 80 columns it read "encoder_scale." over "y"); the headers wrap
    widest = [max((len(part) + 2 for row in rows for part in row[i].split(" + ")), default=0)
              if i == 1 else max((len(row[i]) for row in rows), default=0) for i in range(7)]
    table = Table(show_edge=False, header_style="bold", pad_edge=False)
    for i, col in enumerate(("step", "added", "rms\nbefore", "rms\nafter", "chi2/dof",
                             "p\n(nested)", "dBIC")):
        table.add_column(col, justify="left" if col == "added" else "right", overflow="fold",
                         min_width=widest[i])
    for row in rows:
        table.add_row(*row)
    if sel.steps:
        out.print(table)
        _print_gauge_rms(d)
    for name, p in sel.dropped:
        out.print(f"  dropped {name}: no longer significant beside the others "
                  f"(p = {format_p(p)})")
    if sel.last_considered:
        out.print("  closest candidates that were not taken:")
        for c in sel.last_considered[:3]:
            rms = np.sqrt(c.rss / max(d.capability.n_data, 1))
            out.print(f"    {label(c.added)}: weighted rms {rms * UM_PER_MM:.2f} µm, "
                      f"{c.reason}")
    out.print()


def _print_gauge_rms(d: Diagnosis) -> None:
    gauges = row_labels(d.base_fit.observations).gauge
    models = [d.selection.base] + [s.after for s in d.selection.steps]
    table = table_of("gauge", ">offsets", pad_edge=False,
                     title="residual rms per gauge (µm), before and after each step")
    for step in d.selection.steps:
        table.add_column(f"+ {step.label}", justify="right", overflow="fold")
    per_model = [m.rms_by_gauge(gauges) for m in models]
    for g in per_model[0]:
        table.add_row(g, *(f"{rms[g] * UM_PER_MM:.2f}" for rms in per_model))
    out.print(table)


def _print_outcome_line(d: Diagnosis) -> None:
    """Explained, partly explained or unexplained, and by how much."""
    if d.outcome == "explained":
        out.print(_judged("[bold]with the effects found[/]", d.final))
    elif d.outcome == "partly explained":
        out.print(f"[yellow]No set of library effects brings the fit within the noise.[/] "
                  f"The effects below remove {d.explained_share:.0%} of the misfit beyond "
                  "the noise; their std are inflated by the remaining misfit "
                  f"(x{d.std_inflation:.2f}).")
        out.print(_judged("with them", d.final))
    else:
        out.print("[red]Unexplained[/]: nothing in the effect library brings the fit "
                  "within the gauge noise, so no effect is named.")
        if d.selection.final.effects:
            out.print(f"  the best set tried, {label(d.selection.final.effects)}, removes "
                      f"only {d.explained_share:.0%} of the misfit beyond the noise "
                      f"({paragraph(d.selection.final.verdict)})")


def _print_effect(e: EffectFound, d: Diagnosis, machine_file: str) -> None:
    """One effect found: its value, what its std holds, and what else explains it."""
    out.print(f"  [bold]{e.name}[/] = {measure(e.value, e.std, e.unit)}")
    if e.model_spread > 0.2 * e.std:
        out.print(f"    (std includes ±{e.model_spread:.3g} {e.unit}: the value moves that "
                  "much when another effect is swapped for its alternative)")
    if e.local_disturbance is not None:
        out.print(f"    [yellow]rests on one cell[/]: without {e.local_disturbance} the "
                  "data no longer support it; a disturbance there (a knocked stand, a "
                  "sticking spindle) explains them as well; repeat that posture")
    if e.alternatives:
        alts = ", ".join(f"{a.name} ({a.value:+.4g} {unit(a.name)}, chi2 "
                         f"{a.delta_chi2:+.1f})" for a in e.alternatives)
        out.print(f"    [yellow]explained equally well by[/]: {alts}")
        for sep in e.separations:
            out.print(f"    {shown(sep.describe().replace('M.toml', machine_file))}")
    elif d.final.consistent and e.local_disturbance is None:
        out.print("    no other effect of the library explains these data as well")


def _print_unexplained(d: Diagnosis) -> None:
    """Where the misfit no effect explains sits."""
    if d.unexplained is None:
        return
    along = d.unexplained_along()
    where = "" if along is None else (f" (along the {along['leg']} leg from "
                                      f"{along['from_mm']:+g} to {along['to_mm']:+g} mm)")
    out.print(f"  [red]unexplained[/] misfit sits mostly at "
              f"[bold]{shown(d.unexplained)}[/]{where}")
    if d.remaining is not d.located:
        _print_location("  where the rest sits", d.remaining)


def _print_outcome(d: Diagnosis, machine_file: str) -> None:
    _print_outcome_line(d)
    for e in d.effects:
        if isinstance(e, MapEffect):
            print_map_effect(e)
        else:
            _print_effect(e, d, machine_file)
    for m in d.maps:
        print_axis_map(m)
    _print_unexplained(d)
    out.print()


def _print_offsets(d: Diagnosis) -> None:
    f = d.final_fit
    std = {n: f.std[k] * d.std_inflation for k, n in enumerate(f.names) if n in BASE_MODEL}
    parts = [f"{n.split('.')[1]} {measure(f.value(n), std[n], 'mm')}" for n in BASE_MODEL]
    out.print("joint offsets (final model): " + ", ".join(parts))
    # The offsets absorb what the effects do not: with an alias in an effect's place
    # they move, and writing them back should wait for the alias to be settled.
    for e in d.effects:
        for a in e.alternatives:
            moved = [abs(a.theta[PARAM_INDEX[n]] - f.value(n)) > 3 * std[n] for n in BASE_MODEL]
            if any(moved):
                values = ", ".join(f"{n.split('.')[1]} {a.theta[PARAM_INDEX[n]]:+.4f}"
                                   for n in BASE_MODEL)
                out.print(f"  [yellow]with {a.name} in place of {e.name} they would be[/] "
                          f"{values} mm")
