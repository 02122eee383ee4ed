"""The LinuxCNC table, checked against LinuxCNC's documentation, and read back by a
parser written here from it.

LinuxCNC documentation, "INI Configuration" (docs/src/config/ini-config.adoc),
section [JOINT_n]:
- COMP_FILE: "Each set of values are on one line separated by a space. The first
  value is the nominal value (the commanded position). The second and third values
  depend on the setting of COMP_FILE_TYPE. Points in between nominal values are
  interpolated between the two nominals. Compensation files must start with the
  smallest nominal and be in ascending order [...]. Currently the limit inside
  LinuxCNC is for 256 triplets per joint." Values in machine units.
- COMP_FILE_TYPE 0: the actual position moving in the positive direction, then in
  the negative; 1: the offset from nominal travelling in the positive direction,
  then in the negative. "A COMP_FILE_TYPE must be specified for each COMP_FILE."
- BACKLASH: "If a COMP_FILE is specified for a joint BACKLASH is not used."
How the offset acts: added to the commanded position for the direction of travel
(the type 1 wording; the motion module's compute_screw_comp), so a joint whose
actual position is e past the command needs the offset -e.
"""

from __future__ import annotations

import numpy as np
import pytest

from ogacq.compensation.linuxcnc import LinuxCncOptions, linuxcnc_tables
from tests.compensation.maps import screw_map


def read_comp_file(text: str) -> list[tuple[float, float, float]]:
    """Triplets as LinuxCNC reads them: three numbers a line, reading stops at the first
    line that is not (so a comment line would end the table)."""
    rows = []
    for line in text.splitlines():
        parts = line.split()
        if len(parts) != 3:
            break
        try:
            rows.append(tuple(float(p) for p in parts))
        except ValueError:
            break
    return rows  # type: ignore[return-value]


def trim(rows: list[tuple[float, float, float]], file_type: int, q: np.ndarray,
         direction: int) -> np.ndarray:
    """The offset LinuxCNC adds to the commanded position q moving in ``direction``:
    interpolated between nominals, the end values beyond them."""
    nominal = np.array([r[0] for r in rows])
    column = np.array([r[1] if direction > 0 else r[2] for r in rows])
    offset = column if file_type == 1 else nominal - column  # type 0: actual positions
    out = np.empty_like(q)
    for k, x in enumerate(q):
        if x <= nominal[0]:
            out[k] = offset[0]
        elif x >= nominal[-1]:
            out[k] = offset[-1]
        else:
            i = np.searchsorted(nominal, x) - 1
            t = (x - nominal[i]) / (nominal[i + 1] - nominal[i])
            out[k] = offset[i] + t * (offset[i + 1] - offset[i])
    return out


def test_the_comp_file_is_what_the_documentation_asks():
    m = screw_map()
    tables = linuxcnc_tables({"x": m})
    text = tables.files["x.comp"]
    rows = read_comp_file(text)
    assert len(rows) == len(text.splitlines()) == len(m.positions_mm)  # triplets only
    nominals = [r[0] for r in rows]
    assert all(b > a for a, b in zip(nominals, nominals[1:], strict=False))  # ascending
    assert len(rows) <= 256
    ini = tables.files["linuxcnc.ini"]
    assert "[JOINT_0]" in ini and "COMP_FILE = x.comp" in ini and "COMP_FILE_TYPE = 1" in ini
    assert "BACKLASH is not used while COMP_FILE is set" in ini  # the table replaces it
    for line in ini.splitlines():  # INI comments start their line (; or #)
        assert not line.strip() or line.startswith((";", "#", "[")) or " = " in line, line
    assert "x before: A" in ini and "after (predicted" in ini  # the figures beside it


@pytest.mark.parametrize("file_type", [1, 0])
def test_round_trip_gives_the_same_corrections(file_type):
    """The table read back by the parser above corrects each target by minus the map's
    error, from either side, at the nominals and between them."""
    m = screw_map()
    tables = linuxcnc_tables({"x": m}, LinuxCncOptions(file_type=file_type))
    rows = read_comp_file(tables.files["x.comp"])
    q = np.linspace(-105.0, 65.0, 681)  # between nominals and past the ends
    for direction in (1, -1):
        got = trim(rows, file_type, q, direction)
        np.testing.assert_allclose(got, -m.error_mm(q, direction), atol=2e-6)
        # and what ogacq commands itself for the joint to land at q: the same correction
        # to first order; its fixed-point step differs by at most e times the map's slope
        e = m.error_mm(np.asarray(m.positions_mm), direction)
        slope = np.max(np.abs(np.diff(e) / np.diff(m.positions_mm)))
        ogacq = np.array([m.corrected_target(x, direction) - x for x in q])
        np.testing.assert_allclose(got, ogacq, atol=np.max(np.abs(e)) * slope + 2e-6)
    # the controller's correction as the exporter states it: nothing left at the nominals
    residual = tables.axes["x"].residual_map()
    assert max(map(abs, residual.forward_mm + residual.reverse_mm)) < 2e-6


def test_more_points_than_linuxcnc_takes_are_resampled_and_said():
    m = screw_map(step=0.5)  # 321 positions
    tables = linuxcnc_tables({"x": m})
    rows = read_comp_file(tables.files["x.comp"])
    assert len(rows) == 256 and rows[0][0] == -100.0 and rows[-1][0] == 60.0
    after = tables.axes["x"].after()
    assert after.E > 0  # what the resampling costs, in the figures beside it
