"""A new error-map family is one module: ``throwaway_family.py`` (its shape, search
grid, plausible size, value and words), registered here and nowhere else, is
simulated, found by the search among the built-in families, fitted with the library,
tabulated for the axis's table and shown on the terminal; and no module of ``ogacq``
branches on a family's name outside the registry."""

from __future__ import annotations

import re
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from ogacq.cli.render_diagnosis import print_diagnosis
from ogacq.diagnose.diagnosis import diagnose
from ogacq.model.error_maps import terms_of
from ogacq.model.families import FAMILIES, MapFamily, MapTerm, registered
from ogacq.model.parameters import vector
from ogacq.sim.readings import simulated_readings
from ogacq.sim.truth import SimTruth
from tests.diagnose import throwaway_family
from tests.diagnose.campaigns import MACHINE, NOISE_MM, OFFSETS, STEP_MM, layout

ROOT = Path(__file__).resolve().parents[2]
STEP_AT_MM, STEP_SIZE_MM = -10.0, 0.006


@pytest.fixture
def rail_step() -> Iterator[MapFamily]:
    with registered(throwaway_family.FAMILY) as family:
        yield family


def test_a_family_registered_in_one_module_is_found_fitted_tabulated_and_shown(
        rail_step, capsys):
    term = MapTerm(rail_step.name, 0, {"at_mm": STEP_AT_MM})
    truth = SimTruth(vector(OFFSETS), map_terms=((term, (STEP_SIZE_MM,)),))
    obs = simulated_readings(MACHINE, layout(scan_step_mm=1.0, cycles=1), truth,
                             scatter_mm=NOISE_MM, step_mm=STEP_MM, seed=3)
    d = diagnose(obs)
    [effect] = d.map_effects
    assert effect.name == "rail_step.x" and effect.established
    assert effect.value.extra == {"at_mm": STEP_AT_MM}
    assert abs(effect.value.value - STEP_SIZE_MM) < 3 * effect.std
    assert d.final.consistent
    located = re.search(r"x axis, .*, step where the rail's segments meet at -10 mm, "
                        r"about (\S+) µm$", effect.to_json()["located"])
    assert located and float(located[1]) == pytest.approx(effect.value.value * 1e3, abs=0.05)
    [table] = d.maps
    assert table.axis == "x" and table.source == "step where the rail's segments meet"
    [kept] = terms_of(table)  # the table's terms rebuild the family's term
    assert kept.family == rail_step.name and kept.params == term.params
    before, after = table.error_mm(np.array([-11.0, -9.0]), 1) - table.error_mm(0.0, 1)
    assert after - before == pytest.approx(STEP_SIZE_MM, abs=3 * effect.std)

    print_diagnosis(d)
    text = capsys.readouterr().out
    assert "rail_step.x" in text and "the joint steps at -10 mm (p = " in text


def test_a_family_is_known_only_while_registered():
    with registered(throwaway_family.FAMILY):
        assert MapTerm(throwaway_family.NAME, 1, {"at_mm": 0.0}).where == "y"
        with pytest.raises(ValueError, match="already registered"), \
                registered(throwaway_family.FAMILY):
            pass
    assert throwaway_family.NAME not in FAMILIES
    with pytest.raises(ValueError, match="unknown error-map family 'rail_step'"):
        MapTerm(throwaway_family.NAME, 1, {"at_mm": 0.0})


def test_the_simulator_takes_a_term_along_a_joints_line_by_its_own_shape(rail_step):
    step = (MapTerm(rail_step.name, 0, {"at_mm": 0.0}), (0.002,))
    truth = SimTruth(vector(OFFSETS), map_terms=(step,))
    q = np.array([[-1.0, 5.0, 5.0], [1.0, 5.0, 5.0]])
    assert truth.disturbed_q(q) - q == pytest.approx(np.array([[-0.002, 0, 0], [0, 0, 0]]))
    assert truth.at_temperature(MACHINE, 25.0).map_terms == (step,)
    bow = MapTerm("rail_bow", 0, {"from_mm": -100.0, "to_mm": 60.0, "toward": 1})
    with pytest.raises(ValueError, match="rail_bow.xy: only errors along a joint's line"):
        SimTruth(vector(OFFSETS), map_terms=((bow, (0.01,)),))


def test_a_shape_is_typed_and_its_json_form_kept():
    term = MapTerm("screw_map", 2, {"from_mm": -100.0, "to_mm": 60.0, "knots": 4.0,
                                    "detrended": 1.0})
    assert term.params.knots == 4 and term.params.detrended is True
    assert dict(term.shape) == {"from_mm": -100.0, "to_mm": 60.0, "knots": 4.0,
                                "detrended": 1.0}
    assert MapTerm("screw_map", 2, {"from_mm": 0.0, "to_mm": 1.0, "knots": 0}).params \
        .detrended is False
    with pytest.raises(ValueError, match="screw_map: its shape lacks 'to_mm'"):
        MapTerm("screw_map", 2, {"from_mm": 0.0, "knots": 1})


# a comparison of a family's name, or a table looked up by it: a branch on the family
BRANCH = re.compile(r"\bfamily\s*(==|!=)|\.family\s+(not\s+)?in\b|\.family\]")


def test_no_module_branches_on_a_family_outside_the_registry():
    registry = ROOT / "ogacq" / "model" / "families"
    found = [f"{path.relative_to(ROOT)}:{n}: {line.strip()}"
             for path in sorted((ROOT / "ogacq").rglob("*.py"))
             if registry not in path.parents
             for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1)
             if BRANCH.search(line)]
    assert found == []
