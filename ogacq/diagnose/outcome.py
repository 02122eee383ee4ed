"""The one-word outcome of a diagnosis, shared by the diagnosis and the report."""

from __future__ import annotations


def outcome_label(base_consistent: bool, final_consistent: bool, named_effects: bool) -> str:
    """"consistent", "explained", "partly explained" or "unexplained"."""
    if base_consistent:
        return "consistent"
    if final_consistent:
        return "explained"
    return "partly explained" if named_effects else "unexplained"
