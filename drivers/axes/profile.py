"""Register-map profiles of linear-axis controllers: loading, validation, codec.

A profile (a TOML file in ``drivers/axes/profiles/``) describes everything the
tool needs to drive a controller over Modbus: transport defaults, device ids per
axis, named values (address, table, type, unit), status bits, command sequences,
the offset mechanism, non-volatile save and soft limits. A new controller is
added by writing a profile; the controller client (``controller.py``) and the
simulated controller (``drivers/sim/modbus_server.py``) both read it, so tests
run the real codec.

Validation is strict: unknown or missing keys, wrong types and dangling
references raise :class:`ProfileError` naming the file and the key, because a
typo in a register map would otherwise surface as a write to the wrong address.

The codec (``int_to_words``/``words_to_int``, ``mm_to_counts``/``counts_to_mm``)
is pure and shared by client and simulator.
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any, Literal

from drivers.errors import InputError

SCHEMA_VERSION = 1

WordOrder = Literal["high_first", "low_first"]
Function = Literal["holding", "coil"]
ValueType = Literal["bool", "u16", "s16", "u32", "s32"]
Unit = Literal["mm", "mm/s", "raw"]

VALUE_TYPES: dict[str, tuple[int, bool]] = {  # type -> (registers, signed)
    "bool": (1, False),
    "u16": (1, False),
    "s16": (1, True),
    "u32": (2, False),
    "s32": (2, True),
}
UNITS = ("mm", "mm/s", "raw")
STEP_OPS = ("write", "write_block", "wait", "confirm")
COMMANDS_REQUIRED = ("enable", "disable", "home", "move", "stop", "alarm_reset")
FLAGS_REQUIRED = ("servo_on", "in_position", "moving")
#: Parameters a command step may reference as "$name"; the controller fills them.
STEP_PARAMETERS = (
    "target_mm",
    "band_mm",
    "speed_mm_s",
    "home_position_mm",
    "ack_timeout_s",
    "enable_timeout_s",
    "home_timeout_s",
    "move_timeout_s",
)
AXIS_NAMES = ("x", "y", "z")
#: Function codes a profile may list in [transport].functions: read coils (1), read
#: holding registers (3), write coil (5), write register (6), diagnostics (8, not
#: used by this client), write registers (16). Modbus Application Protocol V1.1b3 §6.
SUPPORTED_FUNCTIONS = (1, 3, 5, 6, 8, 16)


class ProfileError(InputError):
    """A profile file is unreadable, incomplete or inconsistent. Names file and key."""

    def __init__(self, source: str, key: str, problem: str) -> None:
        self.source = source
        self.key = key
        super().__init__(source, f"[{key}] {problem}" if key else problem)


# --------------------------------------------------------------------------- codec


def int_to_words(value: int, words: int, *, word_order: WordOrder, signed: bool) -> list[int]:
    """Split an integer into ``words`` 16-bit registers in the profile's word order."""
    bits = 16 * words
    low, high = (-(1 << (bits - 1)), (1 << (bits - 1)) - 1) if signed else (0, (1 << bits) - 1)
    if not isinstance(value, int) or isinstance(value, bool):
        raise TypeError(f"register value must be an int, got {value!r}")
    if not low <= value <= high:
        kind = "signed" if signed else "unsigned"
        raise ValueError(f"{value} does not fit the {kind} {bits}-bit range [{low}, {high}]")
    raw = value & ((1 << bits) - 1)
    high_first = [(raw >> (16 * (words - 1 - i))) & 0xFFFF for i in range(words)]
    return high_first if word_order == "high_first" else high_first[::-1]


def words_to_int(registers: Sequence[int], *, word_order: WordOrder, signed: bool) -> int:
    """Join 16-bit registers (in the profile's word order) into an integer."""
    ordered = list(registers) if word_order == "high_first" else list(registers)[::-1]
    raw = 0
    for word in ordered:
        if not 0 <= word <= 0xFFFF:
            raise ValueError(f"register value {word} is not a 16-bit word")
        raw = (raw << 16) | word
    bits = 16 * len(ordered)
    if signed and raw & (1 << (bits - 1)):
        raw -= 1 << bits
    return raw


def mm_to_counts(value_mm: float, counts_per_mm: float) -> int:
    """Millimetres (or mm/s) to device counts, rounded to the nearest count."""
    if not math.isfinite(value_mm):
        raise ValueError(f"cannot convert {value_mm} mm to counts")
    return round(value_mm * counts_per_mm)


def counts_to_mm(counts: int, counts_per_mm: float) -> float:
    """Device counts to millimetres (or mm/s)."""
    return counts / counts_per_mm


# --------------------------------------------------------------------------- model


@dataclass(frozen=True)
class TransportDefaults:
    default: Literal["rtu", "tcp"]
    baudrate: int
    bytesize: int
    parity: Literal["N", "E", "O"]
    stopbits: int
    tcp_port: int
    timeout_s: float
    read_retries: int
    #: Modbus function codes the device serves (a drive may lack FC 1/5/6).
    functions: tuple[int, ...] = (1, 3, 5, 6, 16)

    @property
    def single_register_write(self) -> bool:
        """FC 6 for one register; without it, one register goes by FC 16."""
        return 6 in self.functions

    @property
    def bits_per_byte(self) -> int:
        """Bits on the wire per byte: start + data + parity + stop."""
        return 1 + self.bytesize + (0 if self.parity == "N" else 1) + self.stopbits


@dataclass(frozen=True)
class Codec:
    word_order: WordOrder
    counts_per_mm: float
    speed_counts_per_mm_s: float


@dataclass(frozen=True)
class ValueSpec:
    """One named object on the device."""

    name: str
    address: int
    function: Function
    type: ValueType
    unit: Unit
    access: Literal["r", "w", "rw"]

    @property
    def words(self) -> int:
        return VALUE_TYPES[self.type][0]

    @property
    def signed(self) -> bool:
        return VALUE_TYPES[self.type][1]

    @property
    def readable(self) -> bool:
        return "r" in self.access

    @property
    def writable(self) -> bool:
        return "w" in self.access


@dataclass(frozen=True)
class FlagSpec:
    """A status bit: ``bit`` of the 16-bit value ``value``; ``invert`` if 1 means "no"."""

    name: str
    value: str
    bit: int
    invert: bool


@dataclass(frozen=True)
class Step:
    """One step of a command sequence (see the profile files for the step language)."""

    op: Literal["write", "write_block", "wait", "confirm"]
    to: tuple[str, ...] = ()
    value: tuple[Any, ...] = ()
    edge: bool = False
    #: Skip this write when the client's last write of the object was the same value
    #: (see AxisController: the memory is dropped on any fault, error or alarm reset).
    skip_unchanged: bool = False
    flag: str = ""
    state: bool = True
    timeout_s: float | str = "$ack_timeout_s"
    any: tuple[str, ...] = ()
    done: str = ""
    at: float | str = ""


@dataclass(frozen=True)
class Command:
    name: str
    start: tuple[Step, ...]
    finish: tuple[Step, ...]


@dataclass(frozen=True)
class StatusSpec:
    position: str
    alarm_code: str
    alarm_code_read: Literal["always", "on_fault"]
    fault_flags: tuple[str, ...]
    max_gap_registers: int


@dataclass(frozen=True)
class MotionDefaults:
    speed_mm_s: float
    in_position_band_mm: float


@dataclass(frozen=True)
class Limits:
    min_mm: float
    max_mm: float
    margin_mm: float


@dataclass(frozen=True)
class Timing:
    ack_timeout_s: float
    enable_timeout_s: float
    home_timeout_s: float
    move_timeout_s: float


@dataclass(frozen=True)
class OffsetSpec:
    kind: Literal["software", "home_offset"]
    value: str = ""
    sign: int = 1
    write_when_disabled: bool = False


@dataclass(frozen=True)
class NvmSpec:
    kind: Literal["none", "store_parameters"]
    value: str = ""
    signature: int = 0


@dataclass(frozen=True)
class SimSpec:
    soft_limit_alarm_code: int


@dataclass(frozen=True)
class Profile:
    name: str
    family: Literal["iai-robo", "cia402"]
    description: str
    source: str
    transport: TransportDefaults
    device_ids: dict[str, int]
    codec: Codec
    values: dict[str, ValueSpec]
    flags: dict[str, FlagSpec]
    status: StatusSpec
    motion: MotionDefaults
    limits: Limits
    timing: Timing
    offset: OffsetSpec
    nvm: NvmSpec
    commands: dict[str, Command]
    sim: SimSpec

    def value(self, name: str) -> ValueSpec:
        try:
            return self.values[name]
        except KeyError:
            raise KeyError(f"profile {self.name!r} has no value {name!r}") from None

    def scale_of(self, spec: ValueSpec) -> float | None:
        """Counts per unit for a scaled value, None for raw values."""
        if spec.unit == "mm":
            return self.codec.counts_per_mm
        if spec.unit == "mm/s":
            return self.codec.speed_counts_per_mm_s
        return None

    def encode(self, name: str, value: float | int | bool) -> list[int] | bool:
        """A value in user units (mm, mm/s, raw int, bool) to registers (or a coil state)."""
        spec = self.value(name)
        if spec.function == "coil":
            if not isinstance(value, bool):
                raise TypeError(f"coil {name!r} takes a bool, got {value!r}")
            return value
        scale = self.scale_of(spec)
        if scale is None:
            if isinstance(value, bool) or value != int(value):
                raise ValueError(f"raw value {name!r} takes an integer, got {value!r}")
            counts = int(value)
        else:
            counts = mm_to_counts(float(value), scale)
        return int_to_words(
            counts, spec.words, word_order=self.codec.word_order, signed=spec.signed
        )

    def decode(self, name: str, registers: Sequence[int]) -> float | int:
        """Registers of a value to user units (float for scaled values, int for raw)."""
        spec = self.value(name)
        if len(registers) != spec.words:
            raise ValueError(f"{name!r} needs {spec.words} registers, got {len(registers)}")
        counts = words_to_int(registers, word_order=self.codec.word_order, signed=spec.signed)
        scale = self.scale_of(spec)
        return counts if scale is None else counts_to_mm(counts, scale)

    def flag_state(self, name: str, word: int) -> bool:
        flag = self.flags[name]
        return bool(word >> flag.bit & 1) != flag.invert

    def status_values(self) -> list[str]:
        """Values the controller reads for a status poll (alarm code only if always read)."""
        names = [self.status.position]
        names += sorted({flag.value for flag in self.flags.values()})
        if self.status.alarm_code_read == "always":
            names.append(self.status.alarm_code)
        return list(dict.fromkeys(names))


# --------------------------------------------------------------------------- loading


def profiles_folder() -> Path:
    """The folder holding the profiles shipped with the package."""
    return Path(str(resources.files("drivers.axes") / "profiles"))


def available_profiles() -> list[str]:
    return sorted(p.stem for p in profiles_folder().glob("*.toml"))


def load_profile(name_or_path: str | Path) -> Profile:
    """Load a profile by name (``"iai-pcon"``) from the package folder, or from a path."""
    text = str(name_or_path)
    if isinstance(name_or_path, Path) or text.endswith(".toml") or "/" in text:
        path = Path(name_or_path)
    else:
        path = profiles_folder() / f"{text}.toml"
        if not path.is_file():
            raise ProfileError(
                text, "", f"no such profile; available: {', '.join(available_profiles())}"
            )
    try:
        raw = tomllib.loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise ProfileError(str(path), "", f"cannot read: {exc}") from exc
    except tomllib.TOMLDecodeError as exc:
        raise ProfileError(str(path), "", f"not valid TOML: {exc}") from exc
    return parse_profile(raw, source=str(path))


def parse_profile(raw: Mapping[str, Any], *, source: str = "<profile>") -> Profile:
    """Validate a decoded TOML document and build a :class:`Profile`."""
    return _Parser(source).profile(raw)


class _Parser:
    """Table-by-table validation; every error names the file and the dotted key."""

    def __init__(self, source: str) -> None:
        self.source = source

    def fail(self, key: str, problem: str) -> ProfileError:
        return ProfileError(self.source, key, problem)

    def table(
        self,
        raw: Mapping[str, Any],
        key: str,
        required: Sequence[str],
        optional: Sequence[str] = (),
    ) -> dict[str, Any]:
        if not isinstance(raw, Mapping):
            raise self.fail(key, f"must be a table, got {type(raw).__name__}")
        unknown = sorted(set(raw) - set(required) - set(optional))
        if unknown:
            raise self.fail(key, f"unknown key(s) {', '.join(map(repr, unknown))}")
        missing = [k for k in required if k not in raw]
        if missing:
            raise self.fail(key, f"missing key(s) {', '.join(map(repr, missing))}")
        return dict(raw)

    def named_entries(self, raw: Any, key: str) -> dict[str, Any]:
        """A table whose keys are names chosen by the profile's author ([values], [flags])."""
        if not isinstance(raw, Mapping):
            raise self.fail(key, f"must be a table, got {type(raw).__name__}")
        return dict(raw)

    def typed(self, value: Any, kinds: type | tuple[type, ...], key: str) -> Any:
        # bool is an int in Python; a register address of `true` is still a mistake
        if isinstance(value, bool) and bool not in (
            kinds if isinstance(kinds, tuple) else (kinds,)
        ):
            raise self.fail(key, f"must be {self._kind_names(kinds)}, got {value!r}")
        if not isinstance(value, kinds):
            raise self.fail(key, f"must be {self._kind_names(kinds)}, got {value!r}")
        return value

    @staticmethod
    def _kind_names(kinds: type | tuple[type, ...]) -> str:
        kinds = kinds if isinstance(kinds, tuple) else (kinds,)
        return " or ".join(k.__name__ for k in kinds)

    def choice(self, value: Any, options: Sequence[Any], key: str) -> Any:
        if value not in options:
            raise self.fail(key, f"must be one of {', '.join(map(repr, options))}, got {value!r}")
        return value

    def number(self, value: Any, key: str, *, positive: bool = False) -> float:
        number = float(self.typed(value, (int, float), key))
        if not math.isfinite(number) or (positive and number <= 0):
            raise self.fail(
                key, f"must be a {'positive ' if positive else ''}number, got {value!r}"
            )
        return number

    # ---- sections

    def profile(self, raw: Mapping[str, Any]) -> Profile:
        top = self.table(
            raw,
            "",
            required=(
                "schema",
                "name",
                "family",
                "description",
                "transport",
                "axes",
                "codec",
                "values",
                "flags",
                "status",
                "motion",
                "limits",
                "timing",
                "offset",
                "nvm",
                "commands",
                "sim",
            ),
        )
        if top["schema"] != SCHEMA_VERSION:
            raise self.fail(
                "schema", f"this tool reads schema {SCHEMA_VERSION}, got {top['schema']!r}"
            )
        name = self.typed(top["name"], str, "name")
        family = self.choice(top["family"], ("iai-robo", "cia402"), "family")
        description = self.typed(top["description"], str, "description")
        transport = self.transport(top["transport"])
        device_ids = self.axes(top["axes"])
        codec = self.codec(top["codec"])
        values = self.values(top["values"])
        coils = [v.name for v in values.values() if v.function == "coil"]
        if coils and not {1, 5} <= set(transport.functions):
            raise self.fail(f"values.{coils[0]}.function",
                            "a coil needs FC 1 and 5, which [transport].functions leaves out")
        flags = self.flags(top["flags"], values)
        status = self.status(top["status"], values, flags)
        offset = self.offset(top["offset"], values)
        nvm = self.nvm(top["nvm"], values)
        commands = self.commands(top["commands"], values, flags)
        return Profile(
            name=name,
            family=family,
            description=description,
            source=self.source,
            transport=transport,
            device_ids=device_ids,
            codec=codec,
            values=values,
            flags=flags,
            status=status,
            motion=self.motion(top["motion"]),
            limits=self.limits(top["limits"]),
            timing=self.timing(top["timing"]),
            offset=offset,
            nvm=nvm,
            commands=commands,
            sim=self.sim(top["sim"]),
        )

    def transport(self, raw: Any) -> TransportDefaults:
        keys = (
            "default",
            "baudrate",
            "bytesize",
            "parity",
            "stopbits",
            "tcp_port",
            "timeout_s",
            "read_retries",
        )
        t = self.table(raw, "transport", keys, optional=("functions",))
        functions = tuple(self.typed(t.get("functions", [1, 3, 5, 6, 16]), list,
                                     "transport.functions"))
        for i, code in enumerate(functions):
            self.choice(code, SUPPORTED_FUNCTIONS, f"transport.functions[{i}]")
        for needed in (3, 16):
            if needed not in functions:
                raise self.fail("transport.functions", f"must include {needed} (this client "
                                "reads with FC 3 and writes blocks with FC 16)")
        retries = self.typed(t["read_retries"], int, "transport.read_retries")
        if not 0 <= retries <= 5:
            raise self.fail("transport.read_retries", f"must be 0..5, got {retries}")
        return TransportDefaults(
            default=self.choice(t["default"], ("rtu", "tcp"), "transport.default"),
            baudrate=int(self.number(t["baudrate"], "transport.baudrate", positive=True)),
            bytesize=self.choice(t["bytesize"], (7, 8), "transport.bytesize"),
            parity=self.choice(t["parity"], ("N", "E", "O"), "transport.parity"),
            stopbits=self.choice(t["stopbits"], (1, 2), "transport.stopbits"),
            tcp_port=self.typed(t["tcp_port"], int, "transport.tcp_port"),
            timeout_s=self.number(t["timeout_s"], "transport.timeout_s", positive=True),
            read_retries=retries,
            functions=functions,
        )

    def axes(self, raw: Any) -> dict[str, int]:
        a = self.table(raw, "axes", ("device_ids",))
        ids = self.table(a["device_ids"], "axes.device_ids", AXIS_NAMES)
        for axis, dev in ids.items():
            self.typed(dev, int, f"axes.device_ids.{axis}")
            # 0..255 on TCP; RTU allows 1..247 only (checked when the link is chosen)
            if not 0 <= dev <= 255:
                raise self.fail(f"axes.device_ids.{axis}", f"must be 0..255, got {dev}")
        return {axis: ids[axis] for axis in AXIS_NAMES}

    def codec(self, raw: Any) -> Codec:
        c = self.table(raw, "codec", ("word_order", "counts_per_mm", "speed_counts_per_mm_s"))
        return Codec(
            word_order=self.choice(
                c["word_order"], ("high_first", "low_first"), "codec.word_order"
            ),
            counts_per_mm=self.number(c["counts_per_mm"], "codec.counts_per_mm", positive=True),
            speed_counts_per_mm_s=self.number(
                c["speed_counts_per_mm_s"], "codec.speed_counts_per_mm_s", positive=True
            ),
        )

    def values(self, raw: Any) -> dict[str, ValueSpec]:
        table = self.named_entries(raw, "values")
        if not table:
            raise self.fail("values", "defines no value")
        out: dict[str, ValueSpec] = {}
        for name, spec in table.items():
            key = f"values.{name}"
            v = self.table(spec, key, ("address", "function", "type", "unit", "access"))
            address = self.typed(v["address"], int, f"{key}.address")
            function = self.choice(v["function"], ("holding", "coil"), f"{key}.function")
            vtype = self.choice(v["type"], tuple(VALUE_TYPES), f"{key}.type")
            unit = self.choice(v["unit"], UNITS, f"{key}.unit")
            access = self.choice(v["access"], ("r", "w", "rw"), f"{key}.access")
            if (function == "coil") != (vtype == "bool"):
                raise self.fail(f"{key}.type", "coils are type 'bool' and only coils are")
            if function == "coil" and unit != "raw":
                raise self.fail(f"{key}.unit", "a coil has unit 'raw'")
            words = VALUE_TYPES[vtype][0]
            if not 0 <= address <= 0x10000 - words:
                raise self.fail(f"{key}.address", f"{address:#x} is outside 0x0000..0xFFFF")
            out[name] = ValueSpec(name, address, function, vtype, unit, access)
        self._check_overlaps(out)
        return out

    def _check_overlaps(self, values: Mapping[str, ValueSpec]) -> None:
        taken: dict[tuple[str, int], str] = {}
        for spec in values.values():
            for offset in range(spec.words):
                slot = (spec.function, spec.address + offset)
                if slot in taken:
                    raise self.fail(
                        f"values.{spec.name}.address",
                        f"{spec.address + offset:#06x} already belongs to {taken[slot]!r}",
                    )
                taken[slot] = spec.name

    def flags(self, raw: Any, values: Mapping[str, ValueSpec]) -> dict[str, FlagSpec]:
        table = self.named_entries(raw, "flags")
        missing = [name for name in FLAGS_REQUIRED if name not in table]
        if missing:
            raise self.fail("flags", f"missing key(s) {', '.join(map(repr, missing))}")
        out: dict[str, FlagSpec] = {}
        for name, spec in table.items():
            key = f"flags.{name}"
            f = self.table(spec, key, ("value", "bit"), optional=("invert",))
            value = self.typed(f["value"], str, f"{key}.value")
            target = values.get(value)
            if target is None:
                raise self.fail(f"{key}.value", f"no value named {value!r} in [values]")
            if target.function != "holding" or target.words != 1 or not target.readable:
                raise self.fail(f"{key}.value", f"{value!r} must be a readable 16-bit register")
            bit = self.typed(f["bit"], int, f"{key}.bit")
            if not 0 <= bit <= 15:
                raise self.fail(f"{key}.bit", f"must be 0..15, got {bit}")
            invert = self.typed(f.get("invert", False), bool, f"{key}.invert")
            out[name] = FlagSpec(name, value, bit, invert)
        return out

    def status(
        self, raw: Any, values: Mapping[str, ValueSpec], flags: Mapping[str, FlagSpec]
    ) -> StatusSpec:
        s = self.table(
            raw,
            "status",
            ("position", "alarm_code", "alarm_code_read", "fault_flags", "max_gap_registers"),
        )
        position = self._value_ref(s["position"], values, "status.position", readable=True)
        if values[position].unit != "mm":
            raise self.fail("status.position", f"{position!r} must have unit 'mm'")
        alarm = self._value_ref(s["alarm_code"], values, "status.alarm_code", readable=True)
        fault_flags = tuple(self.typed(s["fault_flags"], list, "status.fault_flags"))
        for i, name in enumerate(fault_flags):
            if name not in flags:
                raise self.fail(f"status.fault_flags[{i}]", f"no flag named {name!r} in [flags]")
        gap = self.typed(s["max_gap_registers"], int, "status.max_gap_registers")
        if not 0 <= gap <= 32:
            raise self.fail("status.max_gap_registers", f"must be 0..32, got {gap}")
        return StatusSpec(
            position=position,
            alarm_code=alarm,
            alarm_code_read=self.choice(
                s["alarm_code_read"], ("always", "on_fault"), "status.alarm_code_read"
            ),
            fault_flags=fault_flags,
            max_gap_registers=gap,
        )

    def _value_ref(
        self,
        name: Any,
        values: Mapping[str, ValueSpec],
        key: str,
        *,
        readable: bool = False,
        writable: bool = False,
    ) -> str:
        self.typed(name, str, key)
        spec = values.get(name)
        if spec is None:
            raise self.fail(key, f"no value named {name!r} in [values]")
        if readable and not spec.readable:
            raise self.fail(key, f"{name!r} is not readable (access {spec.access!r})")
        if writable and not spec.writable:
            raise self.fail(key, f"{name!r} is not writable (access {spec.access!r})")
        return name

    def motion(self, raw: Any) -> MotionDefaults:
        m = self.table(raw, "motion", ("speed_mm_s", "in_position_band_mm"))
        return MotionDefaults(
            speed_mm_s=self.number(m["speed_mm_s"], "motion.speed_mm_s", positive=True),
            in_position_band_mm=self.number(
                m["in_position_band_mm"], "motion.in_position_band_mm", positive=True
            ),
        )

    def limits(self, raw: Any) -> Limits:
        lim = self.table(raw, "limits", ("min_mm", "max_mm", "margin_mm"))
        low = self.number(lim["min_mm"], "limits.min_mm")
        high = self.number(lim["max_mm"], "limits.max_mm")
        if low >= high:
            raise self.fail("limits", f"min_mm {low} must be below max_mm {high}")
        margin = self.number(lim["margin_mm"], "limits.margin_mm")
        if margin < 0:
            raise self.fail("limits.margin_mm", f"must be >= 0, got {margin}")
        return Limits(low, high, margin)

    def timing(self, raw: Any) -> Timing:
        keys = ("ack_timeout_s", "enable_timeout_s", "home_timeout_s", "move_timeout_s")
        t = self.table(raw, "timing", keys)
        return Timing(*(self.number(t[k], f"timing.{k}", positive=True) for k in keys))

    def offset(self, raw: Any, values: Mapping[str, ValueSpec]) -> OffsetSpec:
        kind = self.choice(
            raw.get("kind") if isinstance(raw, Mapping) else None,
            ("software", "home_offset"),
            "offset.kind",
        )
        if kind == "software":
            self.table(raw, "offset", ("kind",))
            return OffsetSpec(kind="software")
        o = self.table(raw, "offset", ("kind", "value", "sign", "write_when_disabled"))
        value = self._value_ref(o["value"], values, "offset.value", readable=True, writable=True)
        if values[value].unit != "mm" or values[value].function != "holding":
            raise self.fail("offset.value", f"{value!r} must be a holding register in 'mm'")
        return OffsetSpec(
            kind="home_offset",
            value=value,
            sign=self.choice(o["sign"], (1, -1), "offset.sign"),
            write_when_disabled=self.typed(
                o["write_when_disabled"], bool, "offset.write_when_disabled"
            ),
        )

    def nvm(self, raw: Any, values: Mapping[str, ValueSpec]) -> NvmSpec:
        kind = self.choice(
            raw.get("kind") if isinstance(raw, Mapping) else None,
            ("none", "store_parameters"),
            "nvm.kind",
        )
        if kind == "none":
            self.table(raw, "nvm", ("kind",))
            return NvmSpec(kind="none")
        n = self.table(raw, "nvm", ("kind", "value", "signature"))
        value = self._value_ref(n["value"], values, "nvm.value", writable=True)
        signature = self.typed(n["signature"], int, "nvm.signature")
        if values[value].unit != "raw" or values[value].function != "holding":
            raise self.fail("nvm.value", f"{value!r} must be a raw holding register")
        return NvmSpec(kind="store_parameters", value=value, signature=signature)

    def sim(self, raw: Any) -> SimSpec:
        s = self.table(raw, "sim", ("soft_limit_alarm_code",))
        code = self.typed(s["soft_limit_alarm_code"], int, "sim.soft_limit_alarm_code")
        if not 1 <= code <= 0xFFFF:
            raise self.fail("sim.soft_limit_alarm_code", f"must be 1..0xFFFF, got {code}")
        return SimSpec(soft_limit_alarm_code=code)

    # ---- command sequences

    def commands(
        self, raw: Any, values: Mapping[str, ValueSpec], flags: Mapping[str, FlagSpec]
    ) -> dict[str, Command]:
        table = self.table(raw, "commands", COMMANDS_REQUIRED)
        out: dict[str, Command] = {}
        for name, spec in table.items():
            key = f"commands.{name}"
            c = self.table(spec, key, ("start",), optional=("finish",))
            start = self.steps(c["start"], f"{key}.start", values, flags)
            finish = self.steps(c.get("finish", []), f"{key}.finish", values, flags)
            # An edge-triggered write is never re-sent, so the command must read
            # back whether it was taken: a wait/confirm step has to follow it,
            # later in `start` or in `finish` (after every axis has started).
            for part, steps in (("start", start), ("finish", finish)):
                later = steps + (finish if part == "start" else ())
                for i, step in enumerate(steps):
                    if step.edge and not any(s.op in ("wait", "confirm") for s in later[i + 1 :]):
                        raise self.fail(
                            f"{key}.{part}[{i}]",
                            "an edge-triggered write must be followed by a wait or confirm step",
                        )
            out[name] = Command(name, start, finish)
        return out

    def steps(
        self, raw: Any, key: str, values: Mapping[str, ValueSpec], flags: Mapping[str, FlagSpec]
    ) -> tuple[Step, ...]:
        self.typed(raw, list, key)
        return tuple(self.step(item, f"{key}[{i}]", values, flags) for i, item in enumerate(raw))

    def step(
        self, raw: Any, key: str, values: Mapping[str, ValueSpec], flags: Mapping[str, FlagSpec]
    ) -> Step:
        op = self.choice(raw.get("op") if isinstance(raw, Mapping) else None, STEP_OPS, f"{key}.op")
        if op == "write":
            s = self.table(raw, key, ("op", "to", "value"), optional=("edge", "skip_unchanged"))
            to = self._value_ref(s["to"], values, f"{key}.to", writable=True)
            value = self._step_value(s["value"], values[to], f"{key}.value")
            edge = self._edge(s, key)
            skip = self.typed(s.get("skip_unchanged", False), bool, f"{key}.skip_unchanged")
            if edge and skip:
                raise self.fail(key, "an edge-triggered write is always sent: "
                                     "edge and skip_unchanged exclude each other")
            return Step(op, to=(to,), value=(value,), edge=edge, skip_unchanged=skip)
        if op == "write_block":
            s = self.table(raw, key, ("op", "to", "value"), optional=("edge",))
            names = self.typed(s["to"], list, f"{key}.to")
            given = self.typed(s["value"], list, f"{key}.value")
            if not names or len(names) != len(given):
                raise self.fail(key, "'to' and 'value' must be non-empty lists of equal length")
            refs = [
                self._value_ref(n, values, f"{key}.to[{i}]", writable=True)
                for i, n in enumerate(names)
            ]
            for prev, nxt in zip(refs, refs[1:], strict=False):
                a, b = values[prev], values[nxt]
                if (
                    a.function != "holding"
                    or b.function != "holding"
                    or a.address + a.words != b.address
                ):
                    raise self.fail(
                        f"{key}.to", f"{prev!r} and {nxt!r} are not contiguous registers"
                    )
            vals = tuple(
                self._step_value(v, values[n], f"{key}.value[{i}]")
                for i, (n, v) in enumerate(zip(refs, given, strict=True))
            )
            return Step(op, to=tuple(refs), value=vals, edge=self._edge(s, key))
        if op == "wait":
            s = self.table(raw, key, ("op", "flag", "state"), optional=("timeout_s",))
            flag = self._flag_ref(s["flag"], flags, f"{key}.flag")
            return Step(
                op,
                flag=flag,
                state=self.typed(s["state"], bool, f"{key}.state"),
                timeout_s=self._timeout(s.get("timeout_s", "$ack_timeout_s"), f"{key}.timeout_s"),
            )
        s = self.table(raw, key, ("op", "any", "done", "at"), optional=("timeout_s",))
        any_flags = tuple(
            self._flag_ref(f, flags, f"{key}.any[{i}]")
            for i, f in enumerate(self.typed(s["any"], list, f"{key}.any"))
        )
        at = s["at"]
        if isinstance(at, str):
            self._param(at, f"{key}.at")
        else:
            self.number(at, f"{key}.at")
        return Step(
            op,
            any=any_flags,
            done=self._flag_ref(s["done"], flags, f"{key}.done"),
            at=at,
            timeout_s=self._timeout(s.get("timeout_s", "$ack_timeout_s"), f"{key}.timeout_s"),
        )

    def _edge(self, s: Mapping[str, Any], key: str) -> bool:
        return self.typed(s.get("edge", False), bool, f"{key}.edge")

    def _flag_ref(self, name: Any, flags: Mapping[str, FlagSpec], key: str) -> str:
        self.typed(name, str, key)
        if name not in flags:
            raise self.fail(key, f"no flag named {name!r} in [flags]")
        return name

    def _param(self, text: str, key: str) -> str:
        if not text.startswith("$") or text[1:] not in STEP_PARAMETERS:
            raise self.fail(key, f"{text!r} is not one of ${', $'.join(STEP_PARAMETERS)}")
        return text

    def _timeout(self, raw: Any, key: str) -> float | str:
        if isinstance(raw, str):
            return self._param(raw, key)
        return self.number(raw, key, positive=True)

    def _step_value(self, raw: Any, spec: ValueSpec, key: str) -> Any:
        if isinstance(raw, str):
            return self._param(raw, key)
        if spec.function == "coil":
            return self.typed(raw, bool, key)
        if spec.unit == "raw":
            value = self.typed(raw, int, key)
            bits = 16 * spec.words
            low = -(1 << (bits - 1)) if spec.signed else 0
            high = (1 << (bits - 1)) - 1 if spec.signed else (1 << bits) - 1
            if not low <= value <= high:
                raise self.fail(key, f"{value} does not fit {spec.type} value {spec.name!r}")
            return value
        return self.number(raw, key)
