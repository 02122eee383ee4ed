"""Where the two gauges of a leg go, as plain text (any terminal shows it): half-way
between the tool end and the joint (the papers' Step 1)."""

from __future__ import annotations

import itertools

from ogacq.model.parameters import AXES


def leg_instructions(leg: str) -> list[str]:
    """Plain sentences: where each gauge goes."""
    first, second = (a for a in AXES if a != leg)
    return [
        f"Both gauges touch the {leg} leg half-way between the tool end and the {leg} joint.",
        f"Gauge {first}_{leg}: plunger square to the leg, pushing along {first}.",
        f"Gauge {second}_{leg}: plunger square to the leg, pushing along {second}.",
        "Push each plunger in about half its travel; tighten the magnetic stands.",
    ]


def leg_drawing(leg: str, width: int = 80) -> str:
    """Side view and section side by side, or one above the other on a narrow terminal."""
    first, second = (a for a in AXES if a != leg)
    g1, g2 = f"{first}_{leg}", f"{second}_{leg}"
    side = [
        f"  {leg} leg, from the side",
        "",
        f"  tool o=======+=======o {leg} joint",
        "  end          ^         -> actuator",
        "               |",
        "          gauges here,",
        "         half-way along",
    ]
    push = f"     |   {g1} ==> "
    box = len(push)
    centre = box + 4
    section = [
        f"  section at the gauges, along {leg}",
        "",
        f"     {second}",
        f"{'     ^':<{box}}+-------+",
        f"{push}| {leg} leg |",
        f"{'     +--> ' + first:<{box}}+-------+",
        f"{'':<{centre}}^",
        f"{'':<{centre}}|",
        f"{'':<{centre - 1}}{g2}  pushes along {second}",
    ]
    side_width = max(len(line) for line in side) + 2
    if side_width + max(len(line) for line in section) > width:
        return "\n".join([*side, "", *section])
    return "\n".join(f"{a:<{side_width}}{b}".rstrip()
                     for a, b in itertools.zip_longest(side, section, fillvalue=""))
