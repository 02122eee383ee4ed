"""The table formats ogacq writes: one :class:`TableFormat` each in ``TABLE_FORMATS``,
as ``BACKENDS`` is for gauge protocols (``ogacq_drivers.indicators.backend``).

A format declares

- ``write``: its writer, ``write(maps, options, title=...)`` -> ``ControllerTables``,
  each axis's ``AxisTable.applied`` being the correction the controller applies on the
  table's own grid (interpolated, or a staircase, as its documentation says): the
  residual it leaves, and the ISO 230-2 figures after, are predicted from it;
- ``options``: one set of tables is written per entry (FANUC's with the
  negative-direction table and with the backlash parameter instead);
- ``limits``: its grid (points per axis, how they are spaced), the bound of one value
  and ``finer``, the options with a given spacing and no point limit, from which the
  spacing a map would need is found when the format's own grid cannot carry it;
- ``sign``: what a value is, in words (each file says it too);
- ``sanitise``: every text it writes into a controller file goes through it.

A format defined elsewhere (a plugin, a test) is one module calling :func:`register`;
the campaign file's ``tables`` list reads ``TABLE_FORMATS`` when the file is read.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from typing import Any

from ogacq.compensation import fanuc, linuxcnc, plain_csv, siemens
from ogacq.compensation.tables import ControllerTables
from ogacq.model.axis_map import AxisMap

Writer = Callable[..., ControllerTables]  # write(maps, options, title=...)
Finer = Callable[[Any, float], Any]  # the options with points every ``mm``, no point limit


@dataclass(frozen=True)
class GridLimits:
    """What a format's grid can hold, in words and numbers, with its source."""

    max_points: int | None  # per axis and direction (None: the map's own points)
    spacing: str  # how its points are spaced
    max_value_mm: float | None  # the largest |value| it takes (None: it sets none)
    source: str
    finer: Finer | None = None  # None: the format's points are the map's own


@dataclass(frozen=True)
class TableFormat:
    name: str
    write: Writer
    options: tuple[Any, ...]
    limits: GridLimits
    sign: str
    sanitise: Callable[[str], str]

    def tables(self, maps: Mapping[str, AxisMap], title: str,
               options: Any | None = None) -> list[ControllerTables]:
        """The format's tables of ``maps``, one set per entry of ``options`` (or for
        the one given); the writer makes the title safe (``sanitise``)."""
        chosen = self.options if options is None else (options,)
        return [self.write(maps, o, title=title) for o in chosen]


TABLE_FORMATS: dict[str, TableFormat] = {}


def register(table_format: TableFormat) -> None:
    """One more format (or one replaced by name), a choice of every campaign file read
    after."""
    TABLE_FORMATS[table_format.name] = table_format


def known() -> str:
    """The names registered, for a message."""
    return ", ".join(TABLE_FORMATS)


_NO_POINT_LIMIT = 10**6


def _linuxcnc_finer(options: linuxcnc.LinuxCncOptions, spacing_mm: float,
                    ) -> linuxcnc.LinuxCncOptions:
    # LinuxCNC's nominals are the map's positions, resampled evenly only beyond its
    # 256 triplets: here evenly at the spacing asked, however many that takes
    return replace(options, max_triplets=_NO_POINT_LIMIT, spacing_mm=spacing_mm)


register(TableFormat(
    linuxcnc.FORMAT, linuxcnc.linuxcnc_tables, (linuxcnc.LinuxCncOptions(),),
    GridLimits(linuxcnc.MAX_TRIPLETS, "the map's positions, resampled evenly to at most "
               f"{linuxcnc.MAX_TRIPLETS} triplets", None,
               "LinuxCNC INI Configuration, [JOINT_n] COMP_FILE (at most 256 triplets; "
               "no bound on a value)", _linuxcnc_finer),
    linuxcnc.SIGN, linuxcnc.safe_text))
register(TableFormat(
    fanuc.FORMAT, fanuc.fanuc_tables,
    (fanuc.FanucOptions(), fanuc.FanucOptions(bidirectional=False)),
    GridLimits(fanuc.FanucOptions.max_points, "a whole-mm interval (3624) over at most "
               f"{fanuc.FanucOptions.max_points} positions", None,
               "FANUC Parameter Manual B-63980EN/01, 3620-3624 (the limits per value and "
               "per axis: no source, FanucOptions)",
               lambda o, mm: replace(o, interval_mm=mm, max_points=_NO_POINT_LIMIT)),
    fanuc.SIGN, fanuc.safe_text))
register(TableFormat(
    siemens.FORMAT, siemens.siemens_tables, (siemens.SiemensOptions(),),
    GridLimits(siemens.SiemensOptions.max_points, "a whole-mm _STEP over at most "
               f"{siemens.SiemensOptions.max_points} points", None,
               "SINUMERIK 840D sl FM Extended Functions K3 4.4 (MD38000 points; \"the "
               "size of the compensation value is not limited\")",
               lambda o, mm: replace(o, step_mm=mm, max_points=_NO_POINT_LIMIT)),
    siemens.SIGN, siemens.safe_text))
register(TableFormat(
    plain_csv.FORMAT, plain_csv.csv_tables, (None,),
    GridLimits(None, "the map's positions", None, "no source: ogacq's own layout"),
    plain_csv.SIGN, plain_csv.safe_text))
