"""The one-word outcome of a diagnosis, shared by the diagnosis and the report."""

from __future__ import annotations


def outcome_label(base_consistent: bool, final_consistent: bool, named_effects: bool,
                  judged: bool = True) -> str:
    """"consistent", "explained", "partly explained", "unexplained", or "undetermined"
    when the data leave nothing to judge the fit by. A fit within the noise whose
    residuals still hold a structure the finer tests find (an error map along an
    axis) is "explained" by it."""
    if not judged:
        return "undetermined"
    if base_consistent and not named_effects:
        return "consistent"
    if final_consistent:
        return "explained"
    return "partly explained" if named_effects else "unexplained"
