"""Acceptance of the deviations: the decision rules at their boundaries, missing
evidence never a pass, the JSON form of the record."""

from __future__ import annotations

import pytest

from ogacq.uncertainty.acceptance import (
    Measured,
    acceptance_json,
    evaluate_acceptance,
    tolerances_for,
)

T, U = 0.020, 0.005


def decide(d, u=U, t=T, rule="guard-band"):
    result = evaluate_acceptance({"dx_y+": Measured(d, u)}, {"dx_y+": t}, rule)
    return result.rows[0].decision


@pytest.mark.parametrize(("d", "expected"), [
    (0.0, "pass"),
    (T - U, "pass"),  # |d| = T - U exactly: inside the acceptance zone
    (-(T - U), "pass"),
    (T - U + 1e-6, "undecided"),
    (T, "undecided"),
    (T + U, "undecided"),  # |d| = T + U exactly: not yet beyond it
    (-(T + U), "undecided"),
    (T + U + 1e-6, "fail"),
    (-0.5, "fail"),
])
def test_guard_band_at_its_boundaries(d, expected):
    assert decide(d) == expected


@pytest.mark.parametrize(("d", "expected"), [(T, "pass"), (-T, "pass"), (T + 1e-6, "fail")])
def test_simple_acceptance_at_the_tolerance(d, expected):
    assert decide(d, rule="simple") == expected
    assert decide(d, u=None, rule="simple") == expected  # U not needed, still reported


def test_missing_tolerance_or_u_is_not_evaluated():
    result = evaluate_acceptance(
        {"dx_y+": Measured(0.001, U), "dy_x+": Measured(0.001, None, "budget incomplete"),
         "dx_z+": (0.001, U)},
        {"dx_y+": T, "dy_x+": T, "dz_x-": T}, "guard-band", "as-found")
    rows = {row.deviation: row for row in result.rows}
    assert rows["dx_y+"].decision == "pass"
    assert (rows["dy_x+"].decision, rows["dy_x+"].why) == ("not evaluated",
                                                          "budget incomplete")
    assert (rows["dx_z+"].decision, rows["dx_z+"].why) == ("not evaluated",
                                                          "no tolerance given")
    assert (rows["dz_x-"].decision, rows["dz_x-"].why) == ("not evaluated", "not measured")
    assert result.decision == "not evaluated"  # never a silent pass


@pytest.mark.parametrize(("values", "expected"), [
    ([0.001, 0.002], "pass"),
    ([0.001, 0.018], "undecided"),
    ([0.001, 0.030, 0.018], "fail"),
])
def test_overall_decision(values, expected):
    names = [f"d{a}_{b}+" for a, b in (("x", "y"), ("y", "x"), ("x", "z"))][:len(values)]
    result = evaluate_acceptance({n: Measured(v, U) for n, v in zip(names, values, strict=True)},
                                 dict.fromkeys(names, T))
    assert result.decision == expected


def test_absent_stage_and_the_record_shape():
    found = evaluate_acceptance({"dx_y+": Measured(0.03, U)}, {"dx_y+": T}, "guard-band",
                                "as-found")
    left = evaluate_acceptance(None, {"dx_y+": T}, "guard-band", "as-left")
    assert (left.decision, left.why) == ("not evaluated", "no as-left measurement")
    doc = acceptance_json(found, left)
    assert doc["rule"] == "guard-band"
    assert doc["as_found"]["decision"] == "fail"
    assert doc["as_found"]["rows"][0] == {
        "deviation": "dx_y+", "value_mm": 0.03, "U_mm": U, "tolerance_mm": T,
        "decision": "fail", "why": "|d| > T + U (guard band w = U)"}
    assert doc["as_left"] == {"decision": "not evaluated", "rule": "guard-band", "rows": [],
                              "why": "no as-left measurement"}
    empty = evaluate_acceptance({}, {}, "simple")
    assert empty.decision == "not evaluated" and empty.why == "no deviation to judge"


def test_tolerances_from_a_machine_file():
    assert tolerances_for(["dx_y+", "dy_x+"], 0.02, {"dx_y+": 0.015}) == {
        "dx_y+": 0.015, "dy_x+": 0.02}
    assert tolerances_for(["dx_y+"], None) == {"dx_y+": None}


@pytest.mark.parametrize(("call", "named"), [
    (lambda: evaluate_acceptance({}, {}, "strict"), "decision rule"),
    (lambda: evaluate_acceptance({}, {}, "simple", "as-built"), "stage"),
    (lambda: evaluate_acceptance({}, {"dx_y+": -0.02}), "tolerance of dx_y+"),
    (lambda: evaluate_acceptance({"dx_y+": (0.01, -U)}, {}), "U of deviation dx_y+"),
    (lambda: evaluate_acceptance({"dx_y+": (float("nan"), U)}, {}), "deviation dx_y+"),
])
def test_bad_acceptance_inputs_are_refused_by_name(call, named):
    with pytest.raises(ValueError, match=named):
        call()
