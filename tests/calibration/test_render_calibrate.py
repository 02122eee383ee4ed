"""What ``ogacq calibrate`` prints of a diagnosis, against the record's rule."""

from __future__ import annotations

import io
from types import SimpleNamespace

from rich.console import Console

from ogacq.cli import render_calibrate


def test_a_diagnosis_effect_is_rounded_to_its_std_and_says_it_is_one(monkeypatch):
    """The value to the decimal place of its std (two significant digits, JCGM 100:2008
    7.2.6), as the record's Diagnosis table (value ± std) shows it: it printed
    "+408.3 ± 18 ppm" and "+0.5007 ± 0.015 mrad", with no word of what ± was."""
    out = io.StringIO()
    monkeypatch.setattr(render_calibrate, "console", Console(file=out, width=300))
    effects = [SimpleNamespace(name="encoder_scale.x", value=408.3, std=17.6, unit="ppm"),
               SimpleNamespace(name="squareness.xy", value=0.5007, std=0.0152, unit="mrad")]
    diagnosis = SimpleNamespace(outcome="explained", effects=effects,
                                final=SimpleNamespace(describe=lambda: "within the noise",
                                                      judged=True))
    ui = render_calibrate.TerminalUI(yes=True, on_recorded=None)
    ui.diagnosis("calibration", diagnosis)  # type: ignore[arg-type]
    text = out.getvalue()
    assert ("effects (value ± std, k = 1): encoder_scale.x +408 ± 18 ppm; "
            "squareness.xy +0.501 ± 0.015 mrad") in text, text


def test_a_format_that_left_an_axis_out_says_which_and_why(monkeypatch):
    """A format that wrote some axes and not another shows both: it showed its files
    only, and the reason went unsaid."""
    from tests.compensation.maps import screw_map

    out = io.StringIO()
    monkeypatch.setattr(render_calibrate, "console", Console(file=out, width=300))
    monkeypatch.setattr(render_calibrate.render_offsets, "print_plan", lambda *a, **k: None)
    tables = [{"format": "fanuc", "files": ["/f/tables/fanuc/fanuc.txt"],
               "problem": "fanuc: axis y: needs a spacing <= 1 mm"},
              {"format": "siemens", "files": [], "problem": "siemens: axis x: beyond 1 mm"}]
    comp = SimpleNamespace(uncompensated=(), not_applied=(), maps={"x": screw_map()}, tables=tables)
    ui = render_calibrate.TerminalUI(yes=True, on_recorded=None)
    ui.compensation(comp, SimpleNamespace(refusals=[]), None)  # type: ignore[arg-type]
    text = out.getvalue()
    assert "fanuc table: fanuc.txt; not written: fanuc: axis y: needs a spacing <= 1 mm" in text
    assert "siemens table: not written: siemens: axis x: beyond 1 mm" in text


def test_the_designed_scan_is_printed_before_it_moves(monkeypatch):
    """calibrate shows the separating scan's design (targets, steps, machine time, the
    band of leads, the detection limits) before the scan moves an axis."""
    from ogacq.calibration.separate import SeparatingPlan
    from ogacq.model.machine import PAPER_PROTOTYPE_DIGITAL
    from ogacq.protocol.plan import ProtocolConfig
    from ogacq.protocol.scan_design import design_scan

    out = io.StringIO()
    monkeypatch.setattr(render_calibrate, "console", Console(file=out, width=300))
    design = design_scan(PAPER_PROTOTYPE_DIGITAL, ProtocolConfig(), noise_mm=0.0005,
                         seconds_per_step=5.5, budget_s=2400)
    plan = SeparatingPlan(("the joint offsets rest on 3 positions per leg",), design.protocol,
                          "scan", design.steps, design.duration_s, 5.5, design=design)
    render_calibrate.TerminalUI(yes=True, on_recorded=None).separation(plan, 25.0)
    text = out.getvalue()
    assert "separating measurement: the designed scan of each leg, 411 reading steps" in text
    assert "34 targets from -99 to +59 mm at irregular intervals" in text
    assert "resolves every period from 2 to 40 mm at 4 phases or more" in text
    assert ("detection limit (3 sigma at the gauge noise 0.5 µm): cyclic error 0.8 µm, "
            "smooth map 1.9 µm") in text
    found = design.found_mm["lead_screw_cyclic"] * 1e3
    assert f"a cyclic error is found reliably (95% of them) from about {found:.2g} µm" in text
    # where the scan then finds no map, the end says what it leaves possible
    monkeypatch.setattr(render_calibrate.render_offsets, "print_plan", lambda *a, **k: None)
    ui = render_calibrate.TerminalUI(yes=True, on_recorded=None)
    ui.separation(plan, 25.0)
    ui.compensation(SimpleNamespace(uncompensated=(), not_applied=(), maps={}, tables=[]),  # type: ignore[arg-type]
                    SimpleNamespace(refusals=[]), None)  # type: ignore[arg-type]
    assert (f"no error map to write: the separating scan finds a cyclic error of about "
            f"{found:.2g} µm or more (95% of them); a smaller one may remain") in out.getvalue()


def test_the_end_says_what_a_scan_that_found_no_map_leaves_possible():
    """"validated" after a designed scan that found no map holds for the cyclic errors
    the scan finds: the end says the size below which one may remain (a 10 µm dial's
    rehearsal ended "validated" with a 4 µm lead in place, the size said only while
    the maps were planned)."""
    from ogacq.calibration.procedure import _unseen_below

    design = SimpleNamespace(may_remain=lambda: "a smaller one may remain")
    plan = SimpleNamespace(design=design)
    assert _unseen_below(plan, SimpleNamespace(maps={})) == (  # type: ignore[arg-type]
        "no error map: a smaller one may remain")
    assert _unseen_below(plan, SimpleNamespace(maps={"x": 1})) == ""  # type: ignore[arg-type]
    assert _unseen_below(SimpleNamespace(design=None),  # type: ignore[arg-type]
                         SimpleNamespace(maps={})) == ""  # type: ignore[arg-type]
