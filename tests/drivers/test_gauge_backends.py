"""The table of gauge protocols (``BACKENDS``): every entry carries every part, its
codec reads the example frames of its documents, the simulator's stack serves it and
the station reads it, the README lists it, and nothing outside the table branches on
a protocol's name."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

from ogacq_drivers.errors import DriverError
from ogacq_drivers.indicators import (
    BACKENDS,
    codec,
    register,
    registered,
    same_indicator,
    unregister,
)
from ogacq_drivers.indicators.backend import Backend, Codec, ConnectionHints, Example
from ogacq_drivers.indicators.mitutoyo_01a import decode
from ogacq.campaign.campaign_file import GaugeSpec
from ogacq.campaign.station import open_gauges
from ogacq.sim.stack import make_gauge
from tests.drivers.backend_parts import missing_parts

ROOT = Path(__file__).resolve().parents[2]
PROTOCOLS = list(BACKENDS)


@pytest.mark.parametrize("protocol", PROTOCOLS)
def test_every_backend_has_every_part(protocol: str):
    assert missing_parts(protocol, BACKENDS[protocol]) == []


@pytest.mark.parametrize(("protocol", "a", "b", "same"), [
    ("mitutoyo-01a", None, "1", True),     # the driver asks an unset channel as 1
    ("mitutoyo-01a", None, "2", False),
    ("mitutoyo-01a", "A", "B", False),
    ("uwave", "02", "0002", True),         # CC takes that channel of every group
    ("uwave", "02", "0102", True),
    ("uwave", "0002", "0102", False),      # two groups' channel 02
    ("uwave", "01", "02", False),
    ("uwave", None, "0102", True),         # an unset channel takes whichever it hears
    ("sylvac", "1", "2", True),            # no channels: one indicator per port
    ("digimatic", None, None, True),
])
def test_same_indicator_is_what_the_driver_asks_for(protocol: str, a: str | None,
                                                    b: str | None, same: bool):
    assert same_indicator(protocol, a, b) is same
    assert same_indicator(protocol, b, a) is same


def test_a_backend_lacking_a_part_is_caught():
    whole = BACKENDS["sylvac"]
    broken = Backend(
        "broken", driver="ogacq_drivers.indicators.sylvac:NoSuchDriver",
        codec="ogacq_drivers.indicators.sylvac:decode",  # a function, not a Codec
        simulator="ogacq_drivers.indicators.sylvac:SylvacOptoRS",  # a driver, no simulate()
        hints=ConnectionHints("somewhere", find="ogacq_drivers.indicators.sylvac:REQUEST"),
        settings=whole.settings)
    problems = "\n".join(missing_parts("broken", broken))
    assert "driver 'ogacq_drivers.indicators.sylvac:NoSuchDriver' does not load" in problems
    assert "its codec is a function, not a Codec" in problems
    assert "its simulator has no simulate()" in problems
    assert "hints.find names no function" in problems
    usb_driver_on_a_line = Backend("usb on a line", driver=BACKENDS["usb-itn"].driver,
                                   codec=whole.codec, simulator=whole.simulator,
                                   hints=whole.hints)
    assert missing_parts("x", usb_driver_on_a_line) == [
        "x: its driver cannot be opened as a serial one (got an unexpected keyword argument "
        "'owns_link')"]
    with pytest.raises(TypeError):
        Backend("no simulator", driver=whole.driver, codec=whole.codec,  # type: ignore[call-arg]
                hints=whole.hints)
    with pytest.raises(ValueError, match="'package.module:attribute'"):
        Backend("a path", driver="ogacq_drivers/indicators/sylvac.py", codec=whole.codec,
                simulator=whole.simulator, hints=whole.hints)
    with pytest.raises(ValueError, match="example frames"):
        Codec(decode, lambda *a, **k: b"", examples=(), fixed_width=True)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="document"):
        Example(b"01A+0000.123\r", " ", value_mm=0.123)
    with pytest.raises(ValueError, match="port"):
        ConnectionHints("")


def test_registering_takes_a_new_name_only():
    with registered("sylvac-copy", BACKENDS["sylvac"]):
        assert "sylvac-copy" in BACKENDS
        with pytest.raises(ValueError, match="already registered"):
            register("sylvac-copy", BACKENDS["sylvac"])
    assert "sylvac-copy" not in BACKENDS
    with pytest.raises(ValueError, match="lower-case"):
        register("Sylvac Copy", BACKENDS["sylvac"])
    with pytest.raises(ValueError, match="built in"):
        unregister("sylvac")


@pytest.mark.parametrize("protocol", PROTOCOLS)
def test_every_codec_reads_the_example_frames_of_its_documents(protocol: str):
    for example in codec(protocol).examples:
        if example.error is not None:
            with pytest.raises(DriverError, match="^gauge E: ") as raised:
                codec(protocol).decode(example.frame, where="gauge E")
            assert type(raised.value) is example.error, example
        else:
            decoded = codec(protocol).decode(example.frame, where="gauge E")
            assert decoded.value_mm(example.unit) == pytest.approx(example.value_mm, abs=1e-12)


@pytest.mark.parametrize("protocol", PROTOCOLS)
def test_every_protocol_is_simulated_and_read_through_the_station(protocol: str):
    """The stack's make_gauge and the station's open_gauges, by the protocol's name only."""
    gauge = make_gauge(protocol, lambda: 2.0004, resolution_mm=0.001, transport="pty",
                       name=f"sim {protocol}").start()
    try:
        assert gauge.protocol == protocol
        with open_gauges([GaugeSpec("y_x", protocol, gauge.port)]) as opened:
            assert opened["y_x"].read(timeout_s=2.0).value_mm == 2.0
    finally:
        gauge.close()


def test_the_readme_lists_every_protocol_in_the_tables_order():
    readme = (ROOT / "README.md").read_text()
    section = readme[readme.index("## Cables and interfaces"):]
    section = section[:section.index("\n## ")]
    section = section[section.index("| --- |"):]  # the rows after the header
    rows = re.findall(r"^\| `([a-z0-9-]+)` \|(.*)\|$", section, flags=re.MULTILINE)
    assert [name for name, _ in rows] == PROTOCOLS
    for name, cells in rows:  # each row says where the frames were written from
        assert cells.split("|")[-1].strip(), name


# Where the table replaced branches on a protocol's name; they must not come back.
ITERATING_THE_TABLE = [*sorted((ROOT / "drivers" / "sim").glob("*.py")),
                       ROOT / "ogacq" / "sim" / "stack.py",
                       ROOT / "ogacq" / "cli" / "wizard" / "connect.py"]


def _protocol_branches(path: Path) -> list[str]:
    """``protocol == "x"``, ``protocol in ("x", ...)`` and dicts keyed by protocol names."""
    found = []
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Compare):
            sides = [node.left, *node.comparators]
            named = any(isinstance(s, ast.Name) and s.id == "protocol"
                        or isinstance(s, ast.Attribute) and s.attr == "protocol" for s in sides)
            if named and any(_names_a_protocol(s) for s in sides):
                found.append(f"{path.name}:{node.lineno}")
        elif isinstance(node, ast.Dict) and any(_names_a_protocol(k) for k in node.keys if k):
            found.append(f"{path.name}:{node.lineno}")
    return found


def _names_a_protocol(node: ast.expr) -> bool:
    if isinstance(node, ast.Constant):
        return node.value in BACKENDS
    if isinstance(node, ast.Tuple | ast.List | ast.Set):
        return any(_names_a_protocol(e) for e in node.elts)
    return False


def test_no_branch_on_a_protocol_name_where_the_table_is_iterated():
    assert [b for path in ITERATING_THE_TABLE for b in _protocol_branches(path)] == []


def test_the_branch_finder_finds_branches(tmp_path: Path):
    code = tmp_path / "old.py"
    code.write_text('if self.protocol == "uwave":\n    pass\n'
                    'if protocol in ("sylvac", "x"):\n    pass\n'
                    '_MAX = {"digimatic": 5}\nif kind == "uwave":\n    pass\n')
    assert _protocol_branches(code) == ["old.py:1", "old.py:3", "old.py:5"]
