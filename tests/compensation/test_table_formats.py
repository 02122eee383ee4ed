"""The table formats as one registry (``TABLE_FORMATS``), chosen in the campaign file,
exported into a folder replaced whole, and a table written only where it makes the
axis better: a throwaway format (``throwaway_format.py``), registered here and
nowhere else, goes from a campaign file through the export."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from ogacq.campaign.campaign_file import read_campaign
from ogacq.compensation import export as export_module
from ogacq.compensation.export import export_tables
from ogacq.compensation.formats import TABLE_FORMATS, register
from ogacq.compensation.tables import TableError
from ogacq.errors import InputError, StorageError
from ogacq.model.axis_map import AxisMap
from tests.campaign.conftest import HEAD, MACHINE, gauge
from tests.compensation import throwaway_format
from tests.compensation.maps import screw_map

CONTROLLER = '[controller]\nprofile = "cia402"\nport = "127.0.0.1:1"\n'
GAUGES = "".join(gauge(k, "/dev/ttyUSB0", c) for c, k in
                 enumerate(("y_x", "z_x", "x_y", "z_y", "x_z", "y_z"), 1))


@pytest.fixture
def throwaway() -> Iterator[str]:
    register(throwaway_format.FORMAT)
    try:
        yield throwaway_format.NAME
    finally:
        del TABLE_FORMATS[throwaway_format.NAME]


def smooth_map(axis: str = "x", **kw) -> AxisMap:
    """A scale error with lost motion: every grid here carries it."""
    return screw_map(axis, amplitude_mm=0.0, **kw)


def campaign_with(folder: Path, tables: str) -> Path:
    (folder / "machine.toml").write_text(MACHINE)
    path = folder / "campaign.toml"
    path.write_text(HEAD + CONTROLLER + f"maps_file = \"maps.json\"\ntables = {tables}\n"
                    + GAUGES)
    return path


def test_a_format_registered_in_one_module_runs_from_the_campaign_file(tmp_path, throwaway):
    chosen = read_campaign(campaign_with(tmp_path, f'["{throwaway}", "csv"]')).controller
    assert chosen is not None and chosen.tables == (throwaway, "csv")
    m = smooth_map()
    out = export_tables(tmp_path / "tables", {"x": m}, title="t", formats=chosen.tables)
    assert [e.format for e in out] == [throwaway, "csv"]
    assert sorted(p.name for p in (tmp_path / "tables").iterdir()) == ["csv", throwaway]
    # its file as its writer made it, its sign said, the figures predicted on its grid
    text = (tmp_path / "tables" / throwaway / "table.txt").read_text()
    assert throwaway_format.SIGN in text.splitlines()[0]
    rows = [line.split() for line in text.splitlines()[1:]]
    q = np.array([float(r[1][1:]) for r in rows])
    assert np.allclose(np.diff(q), 4.0)
    assert [float(r[2][1:]) for r in rows] == pytest.approx(-m.error_mm(q, 1), abs=1e-6)
    verdict = out[0].axes["x"]
    assert verdict.written and verdict.before is not None and verdict.after is not None
    assert verdict.after.E < verdict.before.E
    assert out[0].to_json()["axes"]["x"]["written"] is True


def test_an_unknown_format_is_refused_with_the_known_ones(tmp_path):
    with pytest.raises(InputError, match=r"tables\[1\] must be one of .*linuxcnc.*csv"):
        read_campaign(campaign_with(tmp_path, '["csv", "heidenhain"]'))
    with pytest.raises(TableError, match="unknown table format 'heidenhain'; known: linuxcnc"):
        export_tables(tmp_path / "tables", {"x": smooth_map()}, formats=("heidenhain",))
    assert not (tmp_path / "tables").exists()


def test_without_a_choice_every_format_is_written(tmp_path):
    assert read_campaign(campaign_with(tmp_path, '["csv"]')).controller is not None
    out = export_tables(tmp_path / "tables", {"x": smooth_map()})
    assert [e.format for e in out] == ["linuxcnc", "fanuc", "fanuc", "siemens", "csv"]
    assert all(e.files and e.problem is None for e in out)


def test_the_folder_is_replaced_whole_and_a_failure_leaves_the_old_one(tmp_path, monkeypatch):
    folder = tmp_path / "tables"
    export_tables(folder, {"x": smooth_map()}, formats=("csv",))
    (folder / "csv" / "stale.txt").write_text("from before")
    before = (folder / "csv" / "compensation.csv").read_text()
    written = []

    def failing(path, data):  # the disk fills up at the second file
        if written:
            raise StorageError(path, OSError(28, "No space left on device"))
        written.append(path)
        Path(path).write_bytes(data)

    monkeypatch.setattr(export_module, "write_atomically", failing)
    with pytest.raises(StorageError, match="No space left"):
        export_tables(folder, {"x": smooth_map(), "y": smooth_map("y")},
                      formats=("linuxcnc",))
    # the old folder whole, nothing of the new one, nothing left beside
    assert (folder / "csv" / "compensation.csv").read_text() == before
    assert not (folder / "linuxcnc").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["tables"]
    monkeypatch.undo()
    export_tables(folder, {"x": smooth_map()}, formats=("csv",))
    assert not (folder / "csv" / "stale.txt").exists()  # replaced whole
    assert sorted(p.name for p in tmp_path.iterdir()) == ["tables"]


def test_a_grid_that_cannot_follow_the_screw_is_not_written_and_says_why(tmp_path):
    """FANUC's whole-mm interval over 128 positions gives 2 mm over 160 mm: a 4 mm
    pitch is sampled at one phase (the table corrects nothing), a 10 mm pitch by a
    staircase worse than no table; each says the spacing it would need. The formats
    whose grids follow the map are written."""
    for pitch, needed in ((4.0, 1), (10.0, 1)):
        m = screw_map(pitch_mm=pitch, amplitude_mm=0.004, scale_ppm=0.0, lost_mm=0.0,
                      step=0.5)
        out = {e.format: e for e in export_tables(tmp_path / f"t{pitch}", {"x": m})}
        fanuc = out["fanuc"]
        verdict = fanuc.axes["x"]
        assert not verdict.written and fanuc.files == ()
        assert verdict.before is not None and verdict.after is not None
        assert verdict.after.E >= verdict.before.E - 1e-9
        assert f"needs a spacing <= {needed:g} mm" in (verdict.reason or ""), verdict.reason
        assert "gives 2 mm over 160 mm" in (verdict.reason or "")
        assert fanuc.problem == verdict.reason
        assert not (tmp_path / f"t{pitch}" / "fanuc").exists()
        for name in ("linuxcnc", "siemens", "csv"):
            v = out[name].axes["x"]
            assert v.written and v.after is not None and v.before is not None, name
            assert v.after.E < v.before.E and v.after.A <= v.before.A, name


def test_only_the_axis_the_grid_cannot_carry_is_left_out(tmp_path):
    screw = screw_map("y", pitch_mm=10.0, amplitude_mm=0.004, scale_ppm=0.0, lost_mm=0.0,
                      step=0.5)
    out = export_tables(tmp_path / "tables", {"x": smooth_map(), "y": screw},
                        formats=("fanuc",))[0]
    assert out.axes["x"].written and not out.axes["y"].written
    assert set(out.figures) == {"x"}
    text = (tmp_path / "tables" / "fanuc" / "fanuc.txt").read_text()
    assert "axis x" in text and "axis y" not in text
    assert out.problem is not None and out.problem.startswith("fanuc: axis y:")


@pytest.mark.parametrize("value_mm", [5.0, 9945.0, -1.5])
def test_an_implausible_value_is_refused_with_the_axis_and_the_value(tmp_path, value_mm):
    m = smooth_map()
    forward = list(m.forward_mm)
    forward[10] = value_mm
    bad = AxisMap("y", m.positions_mm, tuple(forward), m.reverse_mm, m.u_forward_mm,
                  m.u_reverse_mm, source="forged")
    out = export_tables(tmp_path / "tables", {"x": m, "y": bad})
    for e in out:
        assert e.axes["x"].written and not e.axes["y"].written, e.format
        reason = e.axes["y"].reason or ""
        assert f"axis y: an error of {value_mm:g} mm at {m.positions_mm[10]:g} mm" in reason
        assert "beyond 1 mm" in reason
    csv = (tmp_path / "tables" / "csv" / "compensation.csv").read_text()
    assert not any(line.startswith("y,") for line in csv.splitlines())


def test_a_map_within_its_own_band_is_not_written_and_says_why(tmp_path):
    """Corrected by a map its band could hold from no error, an axis keeps the band's
    mean square where it had the error's (the map's less the band's): a 5 µm cubic
    taken for a 0.7 µm lead made an axis worse, 0.4 -> 1.6 µm rms (bench/
    table_coverage.py, seed 165). Written only where the map's mean square is more
    than twice its band's."""
    kept = screw_map("x", amplitude_mm=0.004, scale_ppm=0.0, lost_mm=0.0, u_mm=0.0015)
    loose = screw_map("y", amplitude_mm=0.004, scale_ppm=0.0, lost_mm=0.0, u_mm=0.0025)
    # rms 2.8 µm beside bands (k = 1) of 1.9 and 3.2 µm: sqrt(u^2 (1 + 1.5^2) / 2)
    out = export_tables(tmp_path / "tables", {"x": kept, "y": loose})
    for e in out:
        if not e.axes["x"].written:  # a grid that cannot follow the 10 mm lead: said so
            assert "no better than none" in (e.axes["x"].reason or ""), e.format
        assert not e.axes["y"].written, e.format
        reason = e.axes["y"].reason or ""
        assert "axis y: the map (test screw map) lies within its own band: rms 2.81 µm " \
            "beside its band's 3.19 µm (k = 1)" in reason, reason
    assert sum(e.axes["x"].written for e in out) >= 3  # LinuxCNC, SINUMERIK, CSV at least


def test_a_bound_the_format_declares_is_kept(tmp_path, throwaway):
    """The throwaway format holds at most 0.5 mm a value (its GridLimits)."""
    m = smooth_map(lost_mm=0.7)  # plausible, beyond the format
    (out,) = export_tables(tmp_path / "tables", {"x": m}, formats=(throwaway,))
    assert not out.axes["x"].written
    assert "beyond 0.5 mm, the most a throwaway value holds" in (out.problem or "")


@pytest.mark.parametrize("name", ["linuxcnc", "fanuc", "siemens", "csv"])
def test_each_table_says_its_sign_and_carries_the_map_u(tmp_path, name):
    m = smooth_map()
    out = export_tables(tmp_path / "tables", {"x": m}, formats=(name,))
    text = "".join(Path(f).read_text() for e in out for f in e.files)
    assert f"sign: {TABLE_FORMATS[name].sign}" in text
    for q, uf, ur in zip(m.positions_mm, m.u_forward_mm, m.u_reverse_mm, strict=True):
        if name == "csv":
            assert f"x,{q:.6f}," in text and f",{2 * max(uf, ur):.6f}," in text
        else:
            assert f"x {q:.3f} {2 * uf:.6f} {2 * ur:.6f}" in text
    if name != "csv":  # the map itself, linear between its points: nothing left between
        assert "x: between its points this table's grid leaves up to" in text


@pytest.mark.parametrize("name", ["linuxcnc", "fanuc", "siemens", "csv"])
def test_the_table_u_holds_what_its_grid_leaves_of_the_map(name):
    """Between a table's points its grid (interpolation, staircase, resampling) leaves
    part of the map: the table's U there covers it, beside the map's own U."""
    m = screw_map(pitch_mm=24.0, amplitude_mm=0.004, step=0.5, u_mm=1e-5)
    fmt = TABLE_FORMATS[name]
    table = fmt.tables({"x": m}, "", fmt.options[0])[0].axes["x"]
    q = np.linspace(-100.0, 60.0, 1601)
    for side in (1, -1):
        left = np.abs(m.error_mm(q, side) - table.applied(q, side))
        assert np.all(left <= table.u_mm(q, side) + 1e-12), name
    assert (table.grid_residual_mm() > 1e-4) == (name == "fanuc")  # its 2 mm staircase


def test_axes_that_fit_alone_but_not_together_are_refused_with_the_reason(tmp_path):
    """A format whose file cannot hold the axes together (a point budget shared by the
    axes, as FANUC's position numbers are) says so and writes nothing of itself."""
    def shared_budget(maps, options, *, title=""):
        if len(maps) > 1:
            raise TableError(f"{len(maps)} axes share 100 points")
        return throwaway_format.write(maps, options, title=title)

    register(replace(throwaway_format.FORMAT, write=shared_budget))
    try:
        (out,) = export_tables(tmp_path / "tables", {"x": smooth_map(), "y": smooth_map("y")},
                               formats=(throwaway_format.NAME,))
    finally:
        del TABLE_FORMATS[throwaway_format.NAME]
    assert out.files == () and out.problem == "throwaway: 2 axes share 100 points"
    assert not any(v.written for v in out.axes.values())
    assert not (tmp_path / "tables" / throwaway_format.NAME).exists()
