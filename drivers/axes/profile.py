"""Register-map profiles of linear-axis controllers: loading, validation, codec.

A profile (a TOML file in ``drivers/axes/profiles/``) describes everything the
tool needs to drive a controller over Modbus: transport defaults, device ids per
axis, named values (address, table, type, unit), status bits, command sequences,
the offset mechanism, non-volatile save and soft limits. A new controller is
added by writing a profile; the controller client (``controller.py``) and the
simulated controller (``drivers/sim/modbus_server.py``) both read it, so tests
run the real codec.

Validation is strict: unknown or missing keys, wrong types (the declared schema
``PROFILE_FILE``) and dangling references raise :class:`ProfileError` naming the
file and the key, because a typo in a register map would otherwise surface as a
write to the wrong address.

The codec (``int_to_words``/``words_to_int``, ``mm_to_counts``/``counts_to_mm``)
is pure and shared by client and simulator.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any, Literal

from ogacq_drivers.config_schema import (
    TRUTH,
    Field,
    Issue,
    ListOf,
    MapOf,
    Source,
    Table,
    Value,
    Variants,
    load,
    number,
    read_document,
    text,
    whole,
)
from ogacq_drivers.errors import InputError

SCHEMA_VERSION = 1

WordOrder = Literal["high_first", "low_first"]
Function = Literal["holding", "coil"]
ValueType = Literal["bool", "u16", "s16", "u32", "s32"]
Unit = Literal["mm", "mm/s", "raw"]

VALUE_TYPES: dict[str, tuple[int, bool]] = {  # type -> (registers, signed)
    "bool": (1, False), "u16": (1, False), "s16": (1, True), "u32": (2, False), "s32": (2, True),
}
UNITS = ("mm", "mm/s", "raw")
COMMANDS_REQUIRED = ("enable", "disable", "home", "move", "stop", "alarm_reset")
FLAGS_REQUIRED = ("servo_on", "in_position", "moving")
#: Parameters a command step may reference as "$name"; the controller fills them.
STEP_PARAMETERS = ("target_mm", "band_mm", "speed_mm_s", "home_position_mm", "ack_timeout_s",
                   "enable_timeout_s", "home_timeout_s", "move_timeout_s")
AXIS_NAMES = ("x", "y", "z")
#: Function codes a profile may list in [transport].functions: read coils (1), read
#: holding registers (3), write coil (5), write register (6), diagnostics (8, not
#: used by this client), write registers (16). Modbus Application Protocol V1.1b3 §6.
SUPPORTED_FUNCTIONS = (1, 3, 5, 6, 8, 16)
#: Registers one FC 16 request may write: 1 to 123 (Modbus Application Protocol V1.1b3 §6.12).
MAX_WRITE_REGISTERS = 123


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
class CommandStep:
    """One step of a command sequence (see the profile files for the step language)."""

    op: Literal["write", "write_block", "wait", "confirm", "cia402_enable"]
    to: tuple[str, ...] = ()
    value: tuple[Any, ...] = ()
    edge: bool = False
    #: Skip this write when the client's last write of the object was the same value
    #: (see AxisController: the memory is dropped on any fault, error or alarm reset).
    skip_unchanged: bool = False
    flag: str = ""
    state: bool = True
    #: A wait for any of several states, each a set of flags that must all hold
    #: (``((("servo_on", False),), (("quick_stop", False), ("in_position", True)))``);
    #: empty for a wait on ``flag`` alone.
    until: tuple[tuple[tuple[str, bool], ...], ...] = ()
    timeout_s: float | str = "$ack_timeout_s"
    any: tuple[str, ...] = ()
    done: str = ""
    at: float | str = ""
    #: The statusword a ``cia402_enable`` step reads the drive's state from.
    status: str = ""


@dataclass(frozen=True)
class Command:
    name: str
    start: tuple[CommandStep, ...]
    finish: tuple[CommandStep, ...]


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
class TemperatureSpec:
    """Registers holding temperatures the campaign may record (``[temperature]``):
    the ambient and/or the machine's, raw counts times ``degc_per_count``, read on
    the drive of ``axis``."""

    degc_per_count: float
    ambient: str = ""
    machine: str = ""
    axis: str = "x"


@dataclass(frozen=True)
class KnownValue:
    """A 32-bit register whose value the drive's kind fixes (``[word_order_check]``):
    ``value & mask == equals`` in the right word order; the pre-flight reads it before
    anything moves, since a value the client wrote reads back alike in either order."""

    value: str
    mask: int
    equals: int


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
    temperature: TemperatureSpec | None = None
    word_order_check: KnownValue | None = None

    @property
    def endpoint_per_axis(self) -> bool:
        """Every axis's drive at the same address (MR-JE-C: unit 255 each): one
        endpoint per axis, not one shared by the three."""
        return len(set(self.device_ids.values())) < len(self.device_ids)

    def value(self, name: str) -> ValueSpec:
        try:
            return self.values[name]
        except KeyError:
            raise KeyError(f"profile {self.name!r} has no value {name!r}") from None

    def scale_of(self, spec: ValueSpec) -> float | None:
        """Counts per unit for a scaled value, None for raw values."""
        if spec.unit == "mm":
            return self.codec.counts_per_mm
        return self.codec.speed_counts_per_mm_s if spec.unit == "mm/s" else None

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
        return int_to_words(counts, spec.words, word_order=self.codec.word_order,
                            signed=spec.signed)

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


# --------------------------------------------------------------------------- the schema
# What each key of a profile file is; the checks across tables (references to values
# and flags, overlapping registers, step values that fit their register) follow below.

_ANY_STEP_VALUE = Value((bool, int, float, str))  # checked against the register written
_TIMEOUT_OR_PARAM = Value((float, str), positive=True)  # seconds or a "$parameter"


def _op(name: str, *fields: Field) -> Table:
    return Table((Field("op", text(name), required=True), *fields))


_STEP = Variants("op", {
    "write": _op("write", Field("to", text(), required=True),
                 Field("value", _ANY_STEP_VALUE, required=True),
                 Field("edge", TRUTH), Field("skip_unchanged", TRUTH)),
    "write_block": _op("write_block", Field("to", ListOf(text()), required=True),
                       Field("value", ListOf(_ANY_STEP_VALUE), required=True),
                       Field("edge", TRUTH)),
    # flag and state, or until = [{FLAG = STATE, ...}, ...]: any one set of flag states
    "wait": _op("wait", Field("flag", text()), Field("state", TRUTH),
                Field("until", ListOf(MapOf(TRUTH, noun="flag"))),
                Field("timeout_s", _TIMEOUT_OR_PARAM)),
    "confirm": _op("confirm", Field("any", ListOf(text()), required=True),
                   Field("done", text(), required=True),
                   Field("at", Value((float, str)), required=True),
                   Field("timeout_s", _TIMEOUT_OR_PARAM)),
    # the CiA 402 state machine walked to "operation enabled" from the state the
    # statusword reports (drivers/axes/cia402.py); timeout_s bounds each transition
    "cia402_enable": _op("cia402_enable", Field("to", text(), required=True),
                         Field("status", text(), required=True),
                         Field("timeout_s", _TIMEOUT_OR_PARAM)),
})


def _required(*fields: tuple[str, Any]) -> tuple[Field, ...]:
    return tuple(Field(key, kind, required=True) for key, kind in fields)


PROFILE_FILE = Table((*_required(
    ("schema", whole(choices=(SCHEMA_VERSION,))),  # the file format version this tool reads
    ("name", text()),
    ("family", text("iai-robo", "cia402")),
    ("description", text()),
    ("transport", Table((
        *_required(("default", text("rtu", "tcp")), ("baudrate", whole(minimum=1)),
                   ("bytesize", whole(choices=(7, 8))), ("parity", text("N", "E", "O")),
                   ("stopbits", whole(choices=(1, 2))),
                   ("tcp_port", whole(minimum=0, maximum=0xFFFF)),
                   ("timeout_s", number(positive=True)),
                   ("read_retries", whole(minimum=0, maximum=5))),
        Field("functions", ListOf(whole(choices=SUPPORTED_FUNCTIONS))),
    ), build=TransportDefaults)),
    # Unit ids: 0..255 on TCP; RTU allows 1..247 only (checked when the link is chosen)
    ("axes", Table(_required(("device_ids", Table(_required(
        *((a, whole(minimum=0, maximum=255)) for a in AXIS_NAMES))))))),
    ("codec", Table(_required(
        ("word_order", text("high_first", "low_first")),
        ("counts_per_mm", number(positive=True)),
        ("speed_counts_per_mm_s", number(positive=True))), build=Codec)),
    ("values", MapOf(Table(_required(
        ("address", whole(minimum=0, maximum=0xFFFF)), ("function", text("holding", "coil")),
        ("type", text(*VALUE_TYPES)), ("unit", text(*UNITS)),
        ("access", text("r", "w", "rw")))), noun="value")),
    ("flags", MapOf(Table((*_required(("value", text()), ("bit", whole(minimum=0, maximum=15))),
                           Field("invert", TRUTH))), noun="flag")),
    ("status", Table(_required(
        ("position", text()), ("alarm_code", text()),
        ("alarm_code_read", text("always", "on_fault")), ("fault_flags", ListOf(text())),
        ("max_gap_registers", whole(minimum=0, maximum=32))))),
    ("motion", Table(_required(("speed_mm_s", number(positive=True)),
                               ("in_position_band_mm", number(positive=True))),
                     build=MotionDefaults)),
    ("limits", Table(_required(("min_mm", number()), ("max_mm", number()),
                               ("margin_mm", number(minimum=0.0))), build=Limits)),
    ("timing", Table(_required(*((k, number(positive=True)) for k in (
        "ack_timeout_s", "enable_timeout_s", "home_timeout_s", "move_timeout_s"))),
        build=Timing)),
    ("offset", Variants("kind", {
        "software": Table(_required(("kind", text("software"))), build=OffsetSpec),
        "home_offset": Table(_required(
            ("kind", text("home_offset")), ("value", text()), ("sign", whole(choices=(1, -1))),
            ("write_when_disabled", TRUTH)), build=OffsetSpec)})),
    ("nvm", Variants("kind", {
        "none": Table(_required(("kind", text("none"))), build=NvmSpec),
        "store_parameters": Table(_required(
            ("kind", text("store_parameters")), ("value", text()),
            ("signature", whole())), build=NvmSpec)})),
    ("commands", Table(_required(*((name, Table((
        Field("start", ListOf(_STEP), required=True), Field("finish", ListOf(_STEP)))))
        for name in COMMANDS_REQUIRED)))),
    ("sim", Table(_required(("soft_limit_alarm_code", whole(minimum=1, maximum=0xFFFF))),
                  build=SimSpec)),
), Field("temperature", Table((
    # optional: temperature registers (a value of [values], raw counts)
    Field("ambient", text()),
    Field("machine", text()),
    Field("degc_per_count", number(positive=True), required=True),
    Field("axis", text(*AXIS_NAMES)),
), build=TemperatureSpec)), Field("word_order_check", Table(_required(
    # optional: a 32-bit raw value whose masked value the drive's kind fixes
    ("value", text()), ("mask", whole(minimum=1, maximum=0xFFFFFFFF)),
    ("equals", whole(minimum=0, maximum=0xFFFFFFFF))), build=KnownValue))))


# --------------------------------------------------------------------------- loading


def profiles_folder() -> Path:
    """The folder holding the profiles shipped with the package."""
    return Path(str(resources.files("ogacq_drivers.axes") / "profiles"))


def available_profiles() -> list[str]:
    return sorted(p.stem for p in profiles_folder().glob("*.toml"))


def _profile_error(issue: Issue) -> ProfileError:
    return ProfileError(issue.file, issue.key, issue.problem)


def load_profile(name_or_path: str | Path) -> Profile:
    """Load a profile by name (``"iai-pcon"``) from the package folder, or from a path."""
    text_ = str(name_or_path)
    if isinstance(name_or_path, Path) or text_.endswith(".toml") or "/" in text_:
        path = Path(name_or_path)
    else:
        path = profiles_folder() / f"{text_}.toml"
        if not path.is_file():
            raise ProfileError(text_, "", "no such profile; available: "
                               f"{', '.join(available_profiles())}")
    try:
        raw, _ = read_document(path, "the profile", _profile_error)
    except FileNotFoundError as exc:
        raise ProfileError(str(path), "", f"cannot read: {exc}") from exc
    return parse_profile(raw, source=str(path))


def parse_profile(raw: Mapping[str, Any], *, source: str = "<profile>") -> Profile:
    """Validate a decoded TOML document and build a :class:`Profile`."""
    given = load(PROFILE_FILE, raw, Source(source, _profile_error))
    return _Checks(source).profile(given)


class _Checks:
    """What the schema cannot say: references between tables, registers that overlap,
    step values that must fit their register. Errors name the file and the dotted key."""

    def __init__(self, source: str) -> None:
        self.source = source

    def fail(self, key: str, problem: str) -> ProfileError:
        return ProfileError(self.source, key, problem)

    def profile(self, top: dict[str, Any]) -> Profile:
        transport: TransportDefaults = top["transport"]
        for needed in (3, 16):
            if needed not in transport.functions:
                raise self.fail("transport.functions", f"must include {needed} (this client "
                                "reads with FC 3 and writes blocks with FC 16)")
        values = self.values(top["values"])
        coils = [v.name for v in values.values() if v.function == "coil"]
        if coils and not {1, 5} <= set(transport.functions):
            raise self.fail(f"values.{coils[0]}.function",
                            "a coil needs FC 1 and 5, which [transport].functions leaves out")
        flags = self.flags(top["flags"], values)
        limits: Limits = top["limits"]
        if limits.min_mm >= limits.max_mm:
            raise self.fail("limits", f"min_mm {limits.min_mm} must be below max_mm "
                            f"{limits.max_mm}")
        return Profile(
            **{key: top[key] for key in ("name", "family", "description", "codec", "motion",
                                         "timing", "sim")},  # as the schema built them
            source=self.source, transport=transport, limits=limits, values=values, flags=flags,
            device_ids={a: top["axes"]["device_ids"][a] for a in AXIS_NAMES},
            status=self.status(top["status"], values, flags),
            offset=self.offset(top["offset"], values), nvm=self.nvm(top["nvm"], values),
            commands=self.commands(top["commands"], values, flags),
            temperature=self.temperature(top.get("temperature"), values),
            word_order_check=self.word_order_check(top.get("word_order_check"), values))

    def word_order_check(self, check: KnownValue | None, values: Mapping[str, ValueSpec],
                         ) -> KnownValue | None:
        if check is None:
            return None
        self._value_ref(check.value, values, "word_order_check.value", readable=True)
        spec = values[check.value]
        if spec.words != 2 or spec.unit != "raw" or spec.function != "holding":
            raise self.fail("word_order_check.value", f"{check.value!r} must be a raw 32-bit "
                            "holding register (u32 or s32)")
        if check.equals & ~check.mask:
            raise self.fail("word_order_check.equals", f"{check.equals:#x} has bits outside "
                            f"the mask {check.mask:#x}")
        return check

    def temperature(self, spec: TemperatureSpec | None, values: Mapping[str, ValueSpec],
                    ) -> TemperatureSpec | None:
        if spec is None:
            return None
        if not spec.ambient and not spec.machine:
            raise self.fail("temperature", "names no register: give 'ambient' and/or "
                            "'machine'")
        for key in ("ambient", "machine"):
            name = getattr(spec, key)
            if not name:
                continue
            self._value_ref(name, values, f"temperature.{key}", readable=True)
            if values[name].unit != "raw" or values[name].function != "holding":
                raise self.fail(f"temperature.{key}",
                                f"{name!r} must be a raw holding register (counts)")
        return spec

    def values(self, table: dict[str, dict[str, Any]]) -> dict[str, ValueSpec]:
        if not table:
            raise self.fail("values", "defines no value")
        out: dict[str, ValueSpec] = {}
        for name, v in table.items():
            key = f"values.{name}"
            spec = ValueSpec(name, **v)
            if (spec.function == "coil") != (spec.type == "bool"):
                raise self.fail(f"{key}.type", "coils are type 'bool' and only coils are")
            if spec.function == "coil" and spec.unit != "raw":
                raise self.fail(f"{key}.unit", "a coil has unit 'raw'")
            if spec.address + spec.words > 0x10000:
                raise self.fail(f"{key}.address", f"{spec.address:#x} is outside 0x0000..0xFFFF")
            out[name] = spec
        self._check_overlaps(out)
        return out

    def _check_overlaps(self, values: Mapping[str, ValueSpec]) -> None:
        taken: dict[tuple[str, int], str] = {}
        for spec in values.values():
            for offset in range(spec.words):
                slot = (spec.function, spec.address + offset)
                if slot in taken:
                    raise self.fail(f"values.{spec.name}.address", f"{spec.address + offset:#06x} "
                                    f"already belongs to {taken[slot]!r}")
                taken[slot] = spec.name

    def flags(self, table: dict[str, dict[str, Any]], values: Mapping[str, ValueSpec],
              ) -> dict[str, FlagSpec]:
        missing = [name for name in FLAGS_REQUIRED if name not in table]
        if missing:
            raise self.fail("flags", f"missing flag {missing[0]!r}")
        out: dict[str, FlagSpec] = {}
        for name, f in table.items():
            key = f"flags.{name}"
            target = values.get(f["value"])
            if target is None:
                raise self.fail(f"{key}.value", f"no value named {f['value']!r} in [values]")
            if target.function != "holding" or target.words != 1 or not target.readable:
                raise self.fail(f"{key}.value",
                                f"{f['value']!r} must be a readable 16-bit register")
            out[name] = FlagSpec(name, f["value"], f["bit"], f.get("invert", False))
        return out

    def status(self, s: dict[str, Any], values: Mapping[str, ValueSpec],
               flags: Mapping[str, FlagSpec]) -> StatusSpec:
        position = self._value_ref(s["position"], values, "status.position", readable=True)
        if values[position].unit != "mm":
            raise self.fail("status.position", f"{position!r} must have unit 'mm'")
        for i, name in enumerate(s["fault_flags"]):
            self._flag_ref(name, flags, f"status.fault_flags[{i}]")
        self._value_ref(s["alarm_code"], values, "status.alarm_code", readable=True)
        return StatusSpec(**s)  # the schema's keys are its fields

    def _value_ref(self, name: str, values: Mapping[str, ValueSpec], key: str, *,
                   readable: bool = False, writable: bool = False) -> str:
        spec = values.get(name)
        if spec is None:
            raise self.fail(key, f"no value named {name!r} in [values]")
        if readable and not spec.readable:
            raise self.fail(key, f"{name!r} is not readable (access {spec.access!r})")
        if writable and not spec.writable:
            raise self.fail(key, f"{name!r} is not writable (access {spec.access!r})")
        return name

    def offset(self, offset: OffsetSpec, values: Mapping[str, ValueSpec]) -> OffsetSpec:
        if offset.kind == "home_offset":
            self._value_ref(offset.value, values, "offset.value", readable=True, writable=True)
            target = values[offset.value]
            if target.unit != "mm" or target.function != "holding":
                raise self.fail("offset.value",
                                f"{offset.value!r} must be a holding register in 'mm'")
        return offset

    def nvm(self, nvm: NvmSpec, values: Mapping[str, ValueSpec]) -> NvmSpec:
        if nvm.kind == "store_parameters":
            self._value_ref(nvm.value, values, "nvm.value", writable=True)
            if values[nvm.value].unit != "raw" or values[nvm.value].function != "holding":
                raise self.fail("nvm.value", f"{nvm.value!r} must be a raw holding register")
        return nvm

    # ---- command sequences

    def commands(self, table: dict[str, dict[str, Any]], values: Mapping[str, ValueSpec],
                 flags: Mapping[str, FlagSpec]) -> dict[str, Command]:
        out: dict[str, Command] = {}
        for name, c in table.items():
            key = f"commands.{name}"
            start = self.steps(c["start"], f"{key}.start", values, flags)
            finish = self.steps(c.get("finish", ()), f"{key}.finish", values, flags)
            # An edge-triggered write is never re-sent, so the command must read
            # back whether it was taken: a wait/confirm step has to follow it,
            # later in `start` or in `finish` (after every axis has started).
            for part, steps in (("start", start), ("finish", finish)):
                later = steps + (finish if part == "start" else ())
                for i, step in enumerate(steps):
                    if step.edge and not any(s.op in ("wait", "confirm") for s in later[i + 1 :]):
                        raise self.fail(f"{key}.{part}[{i}]", "an edge-triggered write must be "
                                        "followed by a wait or confirm step")
            out[name] = Command(name, start, finish)
        return out

    def steps(self, raw: tuple[dict[str, Any], ...], key: str, values: Mapping[str, ValueSpec],
              flags: Mapping[str, FlagSpec]) -> tuple[CommandStep, ...]:
        return tuple(self.step(item, f"{key}[{i}]", values, flags) for i, item in enumerate(raw))

    def step(self, s: dict[str, Any], key: str, values: Mapping[str, ValueSpec],
             flags: Mapping[str, FlagSpec]) -> CommandStep:
        op = s["op"]
        timeout = self._timeout(s.get("timeout_s", "$ack_timeout_s"), f"{key}.timeout_s")
        if op == "write":
            to = self._value_ref(s["to"], values, f"{key}.to", writable=True)
            value = self._step_value(s["value"], values[to], f"{key}.value")
            edge, skip = s.get("edge", False), s.get("skip_unchanged", False)
            if edge and skip:
                raise self.fail(key, "an edge-triggered write is always sent: "
                                     "edge and skip_unchanged exclude each other")
            return CommandStep(op, to=(to,), value=(value,), edge=edge, skip_unchanged=skip)
        if op == "write_block":
            return self._write_block_step(s, key, values)
        if op == "wait":
            if ("until" in s) == ("flag" in s) or ("flag" in s) != ("state" in s):
                raise self.fail(key, "a wait names 'flag' and 'state', or 'until' (a list of "
                                "flag states, any one of which ends it)")
            if "flag" in s:
                return CommandStep(op, flag=self._flag_ref(s["flag"], flags, f"{key}.flag"),
                                   state=s["state"], timeout_s=timeout)
            if not s["until"] or not all(s["until"]):
                raise self.fail(f"{key}.until", "needs at least one set of flag states")
            until = tuple(tuple((self._flag_ref(f, flags, f"{key}.until[{i}].{f}"), bool(v))
                                for f, v in alternative.items())
                          for i, alternative in enumerate(s["until"]))
            return CommandStep(op, until=until, timeout_s=timeout)
        if op == "cia402_enable":
            return CommandStep(op, to=(self._value_ref(s["to"], values, f"{key}.to",
                                                       writable=True),),
                               status=self._value_ref(s["status"], values, f"{key}.status",
                                                   readable=True),
                               timeout_s=timeout)
        any_flags = tuple(self._flag_ref(f, flags, f"{key}.any[{i}]")
                          for i, f in enumerate(s["any"]))
        at = s["at"]
        if isinstance(at, str):
            self._param(at, f"{key}.at")
        return CommandStep(op, any=any_flags, done=self._flag_ref(s["done"], flags,
                                                                  f"{key}.done"),
                           at=at, timeout_s=timeout)

    def _write_block_step(self, s: dict[str, Any], key: str,
                          values: Mapping[str, ValueSpec]) -> CommandStep:
        names, given = s["to"], s["value"]
        if not names or len(names) != len(given):
            raise self.fail(key, "'to' and 'value' must be non-empty lists of equal length")
        refs = [self._value_ref(n, values, f"{key}.to[{i}]", writable=True)
                for i, n in enumerate(names)]
        for prev, nxt in zip(refs, refs[1:], strict=False):
            a, b = values[prev], values[nxt]
            if a.function != "holding" or b.function != "holding" \
                    or a.address + a.words != b.address:
                raise self.fail(f"{key}.to", f"{prev!r} and {nxt!r} are not contiguous "
                                "registers")
        count = sum(values[n].words for n in refs)
        if count > MAX_WRITE_REGISTERS:
            raise self.fail(f"{key}.to", f"{count} registers: one FC 16 request writes "
                            f"{MAX_WRITE_REGISTERS} at most (Modbus Application Protocol "
                            "V1.1b3 §6.12)")
        vals = tuple(self._step_value(v, values[n], f"{key}.value[{i}]")
                     for i, (n, v) in enumerate(zip(refs, given, strict=True)))
        return CommandStep("write_block", to=tuple(refs), value=vals, edge=s.get("edge", False))

    def _flag_ref(self, name: str, flags: Mapping[str, FlagSpec], key: str) -> str:
        if name not in flags:
            raise self.fail(key, f"no flag named {name!r} in [flags]")
        return name

    def _param(self, given: str, key: str) -> str:
        if not given.startswith("$") or given[1:] not in STEP_PARAMETERS:
            raise self.fail(key, f"{given!r} is not one of ${', $'.join(STEP_PARAMETERS)}")
        return given

    def _timeout(self, given: float | str, key: str) -> float | str:
        return self._param(given, key) if isinstance(given, str) else given

    def _step_value(self, given: Any, spec: ValueSpec, key: str) -> Any:
        if isinstance(given, str):
            return self._param(given, key)
        if spec.function == "coil":
            if not isinstance(given, bool):
                raise self.fail(key, f"must be true or false, got {given!r}")
            return given
        if isinstance(given, bool) or (spec.unit == "raw" and not isinstance(given, int)):
            kind = "a whole number" if spec.unit == "raw" else "a number"
            raise self.fail(key, f"must be {kind}, got {given!r}")
        if spec.unit == "raw":
            bits = 16 * spec.words
            low = -(1 << (bits - 1)) if spec.signed else 0
            high = (1 << (bits - 1)) - 1 if spec.signed else (1 << bits) - 1
            if not low <= given <= high:
                raise self.fail(key, f"{given} does not fit {spec.type} value {spec.name!r}")
            return given
        return float(given)
