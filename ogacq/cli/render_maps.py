"""Terminal account of the diagnosis's second look: errors along each axis and in
time (``ogacq diagnose`` without ``--json``). Compact by design: a scan of a few
hundred positions per leg is one line of a profile, a map a few rows of a table."""

from __future__ import annotations

import math

import numpy as np
from rich.markup import escape
from rich.table import Table

from ogacq.cli.plain import Printer, table_of
from ogacq.cli.verdict_text import paragraph
from ogacq.diagnose.diagnosis import Diagnosis
from ogacq.diagnose.maps import MapEffect
from ogacq.diagnose.profile import SPARK, LegProfile
from ogacq.identify.consistency import format_p
from ogacq.model.axis_map import AxisMap
from ogacq.model.gauges import AXES
from ogacq.model.units import UM_PER_MM
from ogacq.uncertainty.reporting import measure

out = Printer()

MAP_ROWS = 9  # positions of a map shown as numbers; the rest as a profile
PROFILE_WIDTH = 48


def print_coverage(d: Diagnosis) -> None:
    mapped = d.mapped
    if mapped is None or not mapped.search.coverage:
        return
    search = mapped.search
    out.print("[bold]Along each axis[/] (errors the library lacks: cyclic and smooth "
              "screw errors, hysteresis building up with travel, rail bows, a warm-up)")
    for cov in search.coverage:
        out.print(f"  {escape(cov.describe())}")
    if not search.searched:
        out.print("  no axis was read densely enough to search for a map along it")
        out.print()
        return
    level = search.level
    table = Table(show_edge=False, header_style="bold", pad_edge=False)
    for col in ("step", "added", "chi2 before", "chi2 after", "p (nested, corrected)",
                "dBIC"):
        # a term's name whole (the headers fold instead): "lead_screw_cycli…" named nothing
        table.add_column(col, justify="left" if col == "added" else "right",
                         no_wrap=col == "added", overflow="fold")
    for k, step in enumerate(search.steps, 1):
        table.add_row(str(k), step.added.term.name, f"{step.rss_before / d.noise.variance:.1f}",
                      f"{step.rss_after / d.noise.variance:.1f}", format_p(step.added.p_value),
                      f"{step.added.delta_bic:+.1f}")
    if search.steps:
        out.print(f"  searched at the {level:g} level, corrected for every shape and "
                  "family tried:")
        out.print(table)
    else:
        out.print(f"  nothing along an axis or in time passes the {level:g} level "
                  "(corrected for every shape and family tried)")
        for c in search.last_considered[:2]:
            out.print(f"    closest: {c.term.name}, {escape(c.reason)}")
    for c in search.unresolved:
        out.print(f"  [yellow]{c.term.name}[/]: a cyclic error beyond the noise (p = "
                  f"{format_p(c.p_value)}), its {escape(c.unresolved)}")
    if mapped.rival is not None:
        out.print(f"  [yellow]explained as well[/]: {escape(mapped.rival.describe())}")
    for name, p in mapped.dropped:
        out.print(f"  dropped {name}: a partial fit of the maps, no longer significant "
                  f"beside them (p = {format_p(p)})")
    if mapped.fit is not None:
        out.print(f"  chi2 with the library's effects {mapped.chi2_before:.1f}, with the "
                  f"maps {mapped.chi2_after:.1f}: {escape(paragraph(d.final))}")
    out.print()


def print_map_effect(e: MapEffect) -> None:
    """One map effect: its sentence, value, further parameters."""
    v = e.value
    unit_value = measure(v.value * UM_PER_MM, e.std * UM_PER_MM, "µm")
    out.print(f"  [bold]{e.name}[/] = {unit_value}: {escape(e.sentence())}")
    extra = {k: val for k, val in v.extra.items() if val is not None and not (
        isinstance(val, float) and math.isnan(val))}
    detail = e.term.kind.detail(extra)
    out.print(f"    {escape(detail)}{' ' if detail else ''}(p = {format_p(e.p_value)})")
    if e.alternatives:
        alts = ", ".join(f"{a.name} (chi2 {a.delta_chi2:+.1f})" for a in e.alternatives)
        out.print(f"    [yellow]explained equally well by[/]: {alts}")
    why = e.not_established()
    if why is not None:
        out.print(f"    [red]{escape(why)}[/]")


def _spark(values: np.ndarray, top: float) -> str:
    out = []
    for v in values:
        if not math.isfinite(v):
            out.append(" ")
            continue
        level = int(np.clip(round(v / top * (len(SPARK) - 1)), 0, len(SPARK) - 1)) \
            if top > 0 else 0
        out.append(SPARK[level])
    return "".join(out)


def print_axis_map(m: AxisMap) -> None:
    """The map with its band: a few positions as numbers, a stretch as a profile. A map
    with a cyclic part is shown over one period from the reference (evenly spaced rows
    over the whole travel would all fall on one phase of it) and said to repeat."""
    q = np.array(m.positions_mm)
    fwd, rev = np.array(m.forward_mm), np.array(m.reverse_mm)
    u_f, u_r = np.array(m.u_forward_mm), np.array(m.u_reverse_mm)
    out.print(f"  [bold]{m.axis} axis map[/] ({escape(m.source)}): {len(q)} positions "
              f"{q[0]:+g} to {q[-1]:+g} mm, actual minus commanded, zero at "
              f"{m.reference_mm:+g} mm forward; band ±u (k = 1)"
              + (f"; without {', '.join(m.excludes)}" if m.excludes else ""))
    pitch = m.extra.get("pitch_mm")
    if pitch:
        start = m.reference_mm if q[0] <= m.reference_mm <= q[-1] - pitch else q[0]
        wanted = start + pitch * np.arange(MAP_ROWS) / (MAP_ROWS - 1)
        stretch = (q >= start) & (q <= start + 2 * pitch)
    else:
        wanted = np.linspace(q[0], q[-1], min(MAP_ROWS, len(q)))
        stretch = np.ones(len(q), dtype=bool)
    pick = np.unique(np.abs(q[None, :] - wanted[:, None]).argmin(axis=1))
    table = table_of(">q (mm)", ">forward (µm)", ">reverse (µm)", pad_edge=False)
    for k in pick:
        table.add_row(f"{q[k]:+.2f}", f"{fwd[k] * UM_PER_MM:+.2f} ± {u_f[k] * UM_PER_MM:.2f}",
                      f"{rev[k] * UM_PER_MM:+.2f} ± {u_r[k] * UM_PER_MM:.2f}")
    out.print(table)
    part = fwd[stretch]
    edges = np.linspace(0, len(part), min(PROFILE_WIDTH, len(part)) + 1).astype(int)
    cells = np.array([part[a:b].mean() for a, b in zip(edges[:-1], edges[1:], strict=True)])
    lo, hi = float(fwd.min()), float(fwd.max())
    where = (f"two periods from {q[stretch][0]:+.2f} mm; it repeats every {pitch:.4g} mm "
             f"to {q[-1]:+g} mm" if pitch else f"{q[0]:+g} to {q[-1]:+g} mm")
    out.print(f"    forward: {_spark(cells - lo, hi - lo)}  ({where}; "
              f"{lo * UM_PER_MM:+.1f} to {hi * UM_PER_MM:+.1f} µm, "
              f"band up to ±{float(u_f.max()) * UM_PER_MM:.2f} µm)")
    if not np.allclose(fwd, rev):
        gap = rev - fwd
        out.print(f"    reverse minus forward: {float(gap.mean()) * UM_PER_MM:+.2f} µm "
                  "(the lost motion)")
    others = m.extra.get("band_alternatives")
    if others:
        named = ", ".join(f"{a['term']} ({a['weight']:.0%})" for a in others)
        out.print(f"    band widened by what terms the search left out would change "
                  f"(their weight by the BIC): {escape(named)}")


def print_profiles(d: Diagnosis) -> None:
    if not d.profiles:
        return
    changed = d.final is not d.base or bool(d.effects)
    out.print("[bold]Misfit along each scanned leg[/] (rms of the residuals per "
              "position bin; one character per bin"
              + (", before and after the effects found)" if changed else ")"))
    sigma = d.noise.sigma_mm
    for p in d.profiles:
        top = float(np.nanmax(p.rms_before_mm))
        leg = AXES[p.leg]
        span = f"q {p.q_mm[0]:+g}..{p.q_mm[-1]:+g} mm"
        out.print(f"  {leg} leg, {span}, scale 0..{top * UM_PER_MM:.1f} µm "
                  f"(noise {sigma * UM_PER_MM:.2g} µm)")
        out.print(f"    before {p.spark(width=PROFILE_WIDTH, top=top)}  "
                  f"{_beyond(p, sigma, False)}")
        if changed:
            out.print(f"    after  {p.spark(after=True, width=PROFILE_WIDTH, top=top)}  "
                      f"{_beyond(p, sigma, True)}")
    out.print()


def _beyond(p: LegProfile, sigma: float, after: bool) -> str:
    span = p.beyond(sigma, after)
    rms = p.rms_after_mm if after else p.rms_before_mm
    whole = float(np.sqrt(np.nansum(rms**2 * p.count) / max(p.count.sum(), 1)))
    where = "within the noise everywhere" if span is None else \
        f"beyond the noise from {span[0]:+g} to {span[1]:+g} mm"
    return f"rms {whole * UM_PER_MM:.2f} µm, {where}"


def print_proposals(d: Diagnosis, machine_file: str) -> None:
    """The scans proposed, pairs that the same scan separates said together."""
    proposals = d.proposals
    if not proposals:
        return
    out.print("[bold]What would tell them apart[/]")
    by_scan: dict[str, list] = {}
    for p in proposals:
        by_scan.setdefault(p.command(machine_file), []).append(p)
    for command, group in by_scan.items():
        first = group[0]
        if first.first == "the effects found":
            out.print(f"  a scan along each leg would show an error along q: every "
                      f"{first.step_mm:g} mm from {first.from_mm:+g} to {first.to_mm:+g} "
                      f"mm, up and back down (`{escape(command)}`)")
        elif not command:
            for p in group:
                out.print(f"  {escape(p.describe(machine_file))}")
        else:
            pairs = "; ".join(f"{p.first} from {p.second} (expected chi-square gap "
                              f"{p.expected_gap:.0f}, now {p.now_gap:+.1f})" for p in group)
            # the command names the session's path, whatever its folders are called
            out.print(f"  to separate {escape(pairs)}: {first.scan_words()} "
                      f"(`{escape(command)}`)")
    out.print()
