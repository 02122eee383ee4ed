"""The simulated linear-axis controller: a real pymodbus server driven by the motion model.

It serves a register-map profile (``drivers/axes/profiles/*.toml``) so the
client's real codec runs end to end, over Modbus TCP on 127.0.0.1 or over RTU
on a pseudo-terminal. One device id per axis (the profile's ``device_ids``).

pymodbus 3.16's ``SimDevice`` calls an ``action`` coroutine on every request
*before* it answers (reads) or stores the request's values (writes). The action
here is where the simulation happens:

- on a write, the written registers/coils go to the device's state and the
  command they carry is executed on the :class:`~ogacq_drivers.sim.motion.MotionModel`
  (servo, home on a rising edge, start a move, CiA 402 controlword transitions...);
- on every request, the dynamic registers (position, status words, alarm code)
  are rewritten from the motion model, so each read reflects simulated "now".

Behaviour comes from the profile's ``family``:

- ``iai-robo``: coils PMSL (Modbus control), SON, HOME (rising edge), ALRS
  (the reset happens on the change back to 0000, as IAI's manual writes it),
  STP (pause: releasing it resumes the remaining distance, as the manual says),
  STOP (deceleration stop: cancels the move, and the coil resets itself); the
  direct-move block starts a move when written; status words from the profile's flags.
- ``cia402``: the CiA 402 state machine on the controlword (0x06 shutdown,
  0x07 switch on, 0x0F enable, bit 7 fault reset on its rising edge, bit 8 halt:
  releasing it continues the positioning, bit 2 low quick stop: cancels it,
  bit 4 new set-point / start homing on its rising edge), modes 1 (profile
  position) and 6 (homing), statusword bits 10 (target reached) and 12
  (set-point acknowledged / homing attained), error code, home offset applied
  at the next homing with the profile's sign convention, store parameters.

Over RTU without a given port, a :class:`~ogacq_drivers.sim.ptybridge.PtyBridge`
stands in for the serial cable and paces bytes at the baud rate (the pymodbus
server itself writes as fast as it can; the bridge, like a real line, makes
them take ``bits_per_byte / baud`` each).

The server runs on its own asyncio loop in a background thread: ``start()``
returns once it is listening, ``stop()`` closes connections and the port.
"""

from __future__ import annotations

import asyncio
import dataclasses
import functools
import logging
import threading
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any, Literal

from pymodbus.constants import ExcCodes
from pymodbus.server import ModbusSerialServer, ModbusTcpServer
from pymodbus.simulator import DataType, SimData, SimDevice

from ogacq_drivers.axes.profile import Profile, ValueSpec, load_profile
from ogacq_drivers.errors import LinkError
from ogacq_drivers.sim.identification import answer_identification
from ogacq_drivers.sim.motion import MotionModel, Outcome
from ogacq_drivers.sim.ptybridge import PtyBridge
from ogacq_drivers.threads import leave_interrupts_to_the_main_thread

log = logging.getLogger(__name__)
# pymodbus logs its own failures; unconfigured, Python's last-resort handler would print them.
logging.getLogger("pymodbus").addHandler(logging.NullHandler())

LOOPBACK_HOSTS = ("127.0.0.1", "::1", "localhost")
STANDARD_GRAVITY_MM_S2 = 9806.65
_COIL_FUNCTIONS = (1, 5, 15)


@dataclass(frozen=True)
class ServerAddress:
    """Where a client finds the simulated controller (what ``ogacq sim --json`` prints)."""

    transport: Literal["tcp", "rtu"]
    host: str | None  # TCP host, None over RTU
    port: int | str  # TCP port, or the serial device path the client opens
    profile: str
    device_ids: dict[str, int]
    baudrate: int | None = None  # RTU only

    def as_dict(self) -> dict[str, Any]:
        info = dataclasses.asdict(self)
        if self.baudrate is None:
            del info["baudrate"]
        return info


# --------------------------------------------------------------------------- device state


@dataclass
class _Registers:
    """The device's memory as the client sees it: holding registers and coils."""

    holding: dict[int, int] = field(default_factory=dict)
    coils: dict[int, bool] = field(default_factory=dict)


class _SimulatedAxis:
    """One Modbus device = one axis; subclasses hold each family's behaviour."""

    required_values: tuple[str, ...] = ()

    def __init__(self, profile: Profile, model: MotionModel, axis: str, device_id: int) -> None:
        missing = [n for n in self.required_values if n not in profile.values]
        if missing:
            raise ValueError(f"profile {profile.name!r} ({profile.source}): the {profile.family} "
                             f"simulator needs value(s) {', '.join(missing)}")
        self.profile = profile
        self.model = model
        self.axis = axis
        self.device_id = device_id
        self.where = f"sim {profile.name} axis {axis} (device {device_id})"
        self.memory = _Registers()
        for spec in profile.values.values():
            if spec.function == "coil":
                self.memory.coils[spec.address] = False
            else:
                for offset in range(spec.words):
                    self.memory.holding[spec.address + offset] = 0

    # ---- typed access to the memory

    def get(self, name: str) -> float | int | bool:
        spec = self.profile.value(name)
        if spec.function == "coil":
            return self.memory.coils[spec.address]
        regs = [self.memory.holding[spec.address + i] for i in range(spec.words)]
        return self.profile.decode(name, regs)

    def put(self, name: str, value: float | int | bool) -> None:
        spec = self.profile.value(name)
        encoded = self.profile.encode(name, value)
        if spec.function == "coil":
            self.memory.coils[spec.address] = bool(encoded)
            return
        assert isinstance(encoded, list)
        for offset, word in enumerate(encoded):
            self.memory.holding[spec.address + offset] = word

    def put_flags(self, states: dict[str, bool]) -> None:
        """Set status bits by flag name in their registers (other bits untouched)."""
        for name, state in states.items():
            flag = self.profile.flags.get(name)
            if flag is None:
                continue
            word = int(self.get(flag.value))
            bit_set = state != flag.invert
            word = word | (1 << flag.bit) if bit_set else word & ~(1 << flag.bit)
            self.put(flag.value, word)

    def _names_at(self, function: str, first: int, count: int) -> list[ValueSpec]:
        return [s for s in self.profile.values.values()
                if s.function == function and s.address < first + count
                and first < s.address + s.words]

    # ---- request entry points (called from the server loop)

    def write_registers(self, address: int, values: list[int]) -> ExcCodes | None:
        for offset, word in enumerate(values):
            self.memory.holding[address + offset] = int(word)
        return self.on_registers_written([s.name for s in self._names_at("holding", address,
                                                                         len(values))])

    def write_coils(self, address: int, values: list[bool]) -> ExcCodes | None:
        changes: list[tuple[str, bool, bool]] = []
        for offset, state in enumerate(values):
            addr = address + offset
            old = self.memory.coils.get(addr, False)
            self.memory.coils[addr] = bool(state)
            changes += [(s.name, old, bool(state)) for s in self._names_at("coil", addr, 1)]
        for name, old, new in changes:
            self.on_coil_written(name, old, new)
        return None

    def refresh(self) -> None:
        """Rewrite the dynamic registers from the motion model."""

    def on_registers_written(self, names: list[str]) -> ExcCodes | None:
        return None

    def on_coil_written(self, name: str, old: bool, new: bool) -> None:
        return None


class _IaiAxis(_SimulatedAxis):
    """IAI ROBO Cylinder PCON behaviour."""

    required_values = ("modbus_control", "servo_on_command", "home_command",
                       "alarm_reset_command", "pause_command", "decel_stop_command",
                       "position_actual", "alarm_code", "move_target", "move_speed",
                       "move_acceleration")

    def __init__(self, profile: Profile, model: MotionModel, axis: str, device_id: int) -> None:
        super().__init__(profile, model, axis, device_id)
        self.alarm_code = 0

    def on_coil_written(self, name: str, old: bool, new: bool) -> None:
        pmsl = bool(self.get("modbus_control"))
        if name in ("servo_on_command", "home_command") and not pmsl:
            log.info("%s: %s ignored: Modbus control (PMSL) is off", self.where, name)
            return
        if name == "servo_on_command":
            self.model.set_servo(self.axis, new)
        elif name == "home_command" and new and not old:
            if self.get("pause_command"):
                log.info("%s: homing ignored: pause (STP) is on", self.where)
                return
            self._note(self.model.home(self.axis, home_position_mm=0.0), "homing")
        elif name == "alarm_reset_command" and old and not new:
            # IAI: ALRS FF00 then 0000, "the reset happens on the change back to 0000"
            self.model.reset_alarm(self.axis)
            self.alarm_code = 0
        elif name == "pause_command" and new:
            self.model.pause(self.axis)
        elif name == "pause_command" and old and not new:
            # IAI: releasing STP resumes the remaining distance of the paused move
            self._note(self.model.resume(self.axis) or Outcome.STARTED, "resume")
        elif name == "decel_stop_command" and new:
            self.model.stop(self.axis)  # cancels the move, paused or not
            self.memory.coils[self.profile.value(name).address] = False  # resets itself

    def on_registers_written(self, names: list[str]) -> ExcCodes | None:
        if "move_target" not in names:
            return None
        if not self.get("modbus_control") or self.get("pause_command"):
            log.info("%s: move ignored: PMSL off or pause on", self.where)
            return None
        accel_g = float(self.get("move_acceleration")) / 100.0
        accel = accel_g * STANDARD_GRAVITY_MM_S2 if accel_g > 0 else None
        outcome = self.model.move_to(self.axis, float(self.get("move_target")),
                                     speed_mm_s=float(self.get("move_speed")) or None,
                                     accel_mm_s2=accel)
        self._note(outcome, "move")
        return None

    def _note(self, outcome: Outcome, what: str) -> None:
        if outcome is Outcome.SOFT_LIMIT:
            self.alarm_code = self.profile.sim.soft_limit_alarm_code
        if outcome is not Outcome.STARTED:
            log.info("%s: %s %s", self.where, what, outcome.value)

    def refresh(self) -> None:
        snap = self.model.snapshot(self.axis)
        if snap.alarm is None:
            self.alarm_code = 0
        elif self.alarm_code == 0:
            self.alarm_code = self.profile.sim.soft_limit_alarm_code
        self.put("position_actual", snap.counter_mm)
        self.put("alarm_code", self.alarm_code)
        self.put_flags({"emergency_stop": False, "servo_on": snap.servo_on,
                        "alarm": snap.alarm is not None, "homed": snap.homed,
                        "in_position": snap.servo_on and snap.in_position,
                        "moving": snap.moving})


# CiA 402 statusword state patterns (bits 0-3, 5, 6) and fixed bits.
_SW_READY, _SW_SWITCHED_ON, _SW_ENABLED, _SW_FAULT = 0x0001, 0x0002, 0x0004, 0x0008
_SW_VOLTAGE, _SW_QUICK_STOP_OFF, _SW_SWITCH_ON_DISABLED, _SW_REMOTE = 0x0010, 0x0020, 0x0040, 0x0200
_SW_TARGET_REACHED, _SW_BIT12 = 0x0400, 0x1000
_CW_SWITCH_ON, _CW_ENABLE_VOLTAGE, _CW_QUICK_STOP, _CW_ENABLE_OPERATION = 0x01, 0x02, 0x04, 0x08
_CW_NEW_SETPOINT, _CW_RELATIVE, _CW_FAULT_RESET, _CW_HALT = 0x10, 0x40, 0x80, 0x100
_MODE_PROFILE_POSITION, _MODE_HOMING = 1, 6
# CiA 301 1000h device type: profile 402 (0x0192) in bits 0-15; bits 16-23 the drive
# type, 02h a servo drive [CiA 402-2, device type]
_DEVICE_TYPE_SERVO = 0x0002_0192

_STATE_WORDS = {
    "switch_on_disabled": _SW_SWITCH_ON_DISABLED,
    "ready_to_switch_on": _SW_READY | _SW_QUICK_STOP_OFF | _SW_VOLTAGE,
    "switched_on": _SW_READY | _SW_SWITCHED_ON | _SW_QUICK_STOP_OFF | _SW_VOLTAGE,
    "operation_enabled": _SW_READY | _SW_SWITCHED_ON | _SW_ENABLED | _SW_QUICK_STOP_OFF
    | _SW_VOLTAGE,
    "fault": _SW_FAULT,
}
_CIA_FLAG_BITS = {"servo_on": 2, "fault": 3, "in_position": 10, "setpoint_ack": 12,
                  "homing_attained": 12}


class _CiaAxis(_SimulatedAxis):
    """A CiA 402 drive (one per axis) with objects mapped at their index."""

    # home_offset, store_parameters, mode_display and error_code are served when the
    # profile maps them (a drive whose map has no source for them leaves them out)
    required_values = ("controlword", "statusword", "mode", "position_actual",
                       "target_position", "profile_velocity")

    def __init__(self, profile: Profile, model: MotionModel, axis: str, device_id: int) -> None:
        super().__init__(profile, model, axis, device_id)
        for name, bit in _CIA_FLAG_BITS.items():
            flag = profile.flags.get(name)
            if flag is not None and (flag.value != "statusword" or flag.bit != bit or flag.invert):
                raise ValueError(f"profile {profile.name!r}: flag {name!r} must be statusword bit "
                                 f"{bit} for the CiA 402 simulator")
        self.state = "switch_on_disabled"
        self.controlword = 0
        self.setpoint_ack = False
        self.error_code = 0
        self.nvm_saves = 0
        self.put("profile_velocity", model.speed_mm_s)
        self.put("mode", _MODE_PROFILE_POSITION)
        if "device_type" in profile.values:
            self.put("device_type", _DEVICE_TYPE_SERVO)

    @property
    def mode(self) -> int:
        return int(self.get("mode"))

    def on_registers_written(self, names: list[str]) -> ExcCodes | None:
        if "store_parameters" in names and "store_parameters" in self.profile.values:
            return self._store_parameters()
        if "home_offset" in names:
            log.info("%s: home offset set to %.3f mm (effective at the next homing)",
                     self.where, self.get("home_offset"))
        if "controlword" in names:
            self._controlword(int(self.get("controlword")))
        return None

    def _store_parameters(self) -> ExcCodes | None:
        signature = int(self.get("store_parameters"))
        self.put("store_parameters", 0)
        if signature != self.profile.nvm.signature:
            log.warning("%s: store parameters refused: signature %#010x", self.where, signature)
            return ExcCodes.ILLEGAL_VALUE
        self.nvm_saves += 1
        log.info("%s: parameters stored to NVM (save #%d)", self.where, self.nvm_saves)
        return None

    def _controlword(self, cw: int) -> None:
        old, self.controlword = self.controlword, cw
        rising = cw & ~old
        falling = old & ~cw
        self._sync_fault()
        if rising & _CW_FAULT_RESET:
            if self.state == "fault":
                self.model.reset_alarm(self.axis)
                self.error_code = 0
                self.state = "switch_on_disabled"
                log.info("%s: fault reset", self.where)
            return
        if self.state == "fault" or cw & _CW_FAULT_RESET:
            return
        self.state = self._next_state(cw)
        enabled = self.state == "operation_enabled"
        self.model.set_servo(self.axis, enabled)
        if not enabled:
            self.setpoint_ack = False
            return
        if rising & _CW_HALT:
            self.model.pause(self.axis)
        elif falling & _CW_HALT and self.mode == _MODE_PROFILE_POSITION:
            # CiA 402 profile position, halt = 0: "execute or continue the positioning"
            self._note(self.model.resume(self.axis) or Outcome.STARTED, "halt released")
        if falling & _CW_NEW_SETPOINT:
            self.setpoint_ack = False
        if rising & _CW_NEW_SETPOINT and not cw & _CW_HALT:
            self._new_setpoint(cw)

    def _next_state(self, cw: int) -> str:
        state = self.state
        if not cw & _CW_ENABLE_VOLTAGE or not cw & _CW_QUICK_STOP:
            return "switch_on_disabled"  # disable voltage / quick stop
        if not cw & _CW_SWITCH_ON:
            return "ready_to_switch_on" if state != "fault" else state  # shutdown
        if not cw & _CW_ENABLE_OPERATION:  # switch on / disable operation
            return "switched_on" if state != "switch_on_disabled" else state
        # enable operation (from ready-to-switch-on the drive passes switched-on itself)
        return "operation_enabled" if state != "switch_on_disabled" else state

    def _new_setpoint(self, cw: int) -> None:
        if self.mode == _MODE_HOMING:
            home_offset_mm = (float(self.get("home_offset"))
                              if "home_offset" in self.profile.values else 0.0)
            outcome = self.model.home(self.axis,
                                      home_position_mm=self.profile.offset.sign * home_offset_mm)
            self._note(outcome, "homing")
        elif self.mode == _MODE_PROFILE_POSITION:
            target = float(self.get("target_position"))
            if cw & _CW_RELATIVE:
                target += self.model.snapshot(self.axis).target_counter_mm
            outcome = self.model.move_to(self.axis, target,
                                         speed_mm_s=float(self.get("profile_velocity")) or None)
            self._note(outcome, "set-point")
            self.setpoint_ack = outcome is Outcome.STARTED
        else:
            log.info("%s: start ignored in unsupported mode %d", self.where, self.mode)

    def _note(self, outcome: Outcome, what: str) -> None:
        if outcome is not Outcome.STARTED:
            log.info("%s: %s %s", self.where, what, outcome.value)
        self._sync_fault()

    def _sync_fault(self) -> None:
        """A motion-model alarm puts the drive in FAULT, power stage off."""
        snap = self.model.snapshot(self.axis)
        if snap.alarm is not None and self.state != "fault":
            self.state = "fault"
            self.error_code = self.profile.sim.soft_limit_alarm_code
            self.setpoint_ack = False
            self.model.set_servo(self.axis, False)
            log.warning("%s: fault, error code %#06x", self.where, self.error_code)

    def refresh(self) -> None:
        self._sync_fault()
        snap = self.model.snapshot(self.axis)
        word = _STATE_WORDS[self.state] | _SW_REMOTE
        if snap.in_position:
            word |= _SW_TARGET_REACHED
        if self.mode == _MODE_HOMING:
            if snap.homed and not snap.homing:
                word |= _SW_BIT12  # homing attained
        elif self.setpoint_ack:
            word |= _SW_BIT12  # set-point acknowledged
        self.put("statusword", word)
        if "mode_display" in self.profile.values:
            self.put("mode_display", self.mode)
        self.put("position_actual", snap.counter_mm)
        if "error_code" in self.profile.values:
            self.put("error_code", self.error_code)


_FAMILIES: dict[str, type[_SimulatedAxis]] = {"iai-robo": _IaiAxis, "cia402": _CiaAxis}


# --------------------------------------------------------------------------- server


class ModbusSimServer:
    """A pymodbus server for one profile, over TCP (127.0.0.1) or RTU (pty), in a thread.

    >>> with ModbusSimServer("cia402", model) as server:   # doctest: +SKIP
    ...     info = server.address.as_dict()
    """

    def __init__(self, profile: Profile | str, motion: MotionModel, *,
                 transport: Literal["tcp", "rtu"] | None = None, host: str = "127.0.0.1",
                 port: int = 0, serial_port: str | None = None, axes: Iterable[str] | None = None,
                 temperatures_c: Callable[[], Mapping[str, float]] | None = None) -> None:
        self.profile = profile if isinstance(profile, Profile) else load_profile(profile)
        self.motion = motion
        self.transport = transport or self.profile.transport.default
        if self.transport not in ("tcp", "rtu"):
            raise ValueError("sim server: transport must be 'tcp' or 'rtu', got "
                             f"{self.transport!r}")
        if host not in LOOPBACK_HOSTS:
            raise ValueError(f"sim server: binds loopback only, got host {host!r}")
        self.host = host
        self.port = port
        self.serial_port = serial_port
        self.baudrate = self.profile.transport.baudrate
        # what the profile's [temperature] registers show: {"ambient": degC, "machine": ...}
        self.temperatures_c = temperatures_c or (lambda: {"ambient": 20.0, "machine": 20.0})
        # the axes behind this endpoint: all (one bus), or one (a drive per address)
        self.axes = tuple(axes) if axes is not None else tuple(self.profile.device_ids)
        missing = [a for a in self.axes if a not in motion.axes]
        if missing:
            raise ValueError(f"sim server: motion model lacks axes {missing}")
        ids = [self.profile.device_ids[a] for a in self.axes]
        if len(set(ids)) != len(ids):
            raise ValueError(f"sim server: axes {list(self.axes)} share a device id in profile "
                             f"{self.profile.name!r}: serve one axis per endpoint")
        family = _FAMILIES[self.profile.family]
        self.devices: dict[int, _SimulatedAxis] = {
            self.profile.device_ids[axis]: family(self.profile, motion, axis,
                                                  self.profile.device_ids[axis])
            for axis in self.axes
        }
        self._bridge: PtyBridge | None = None
        self._thread: threading.Thread | None = None
        self._loop: asyncio.AbstractEventLoop | None = None
        self._stop_event: asyncio.Event | None = None
        self._ready = threading.Event()
        self._failure: BaseException | None = None
        self._address: ServerAddress | None = None

    # ---- life cycle

    def start(self, timeout_s: float = 5.0) -> ServerAddress:
        """Start serving; returns once the server listens (or raises LinkError)."""
        if self._thread is not None:
            return self.address
        listen_on = client_port = self.serial_port or ""
        if self.transport == "rtu" and not self.serial_port:
            self._bridge = PtyBridge(baudrate=self.baudrate,
                                     bits_per_byte=self.profile.transport.bits_per_byte).start()
            listen_on, client_port = self._bridge.server_path, self._bridge.client_path
        self._ready.clear()
        self._failure = None
        self._thread = threading.Thread(target=self._run, args=(listen_on,),
                                        name=f"sim-modbus-{self.profile.name}", daemon=True)
        self._thread.start()
        if not self._ready.wait(timeout_s) or self._failure is not None:
            failure = self._failure
            self.stop()
            endpoint = listen_on if self.transport == "rtu" else f"{self.host}:{self.port}"
            where = f"sim {self.profile.name} {self.transport} {endpoint}"
            raise LinkError("simulated controller could not listen (address in use, or port not "
                            f"available?): {failure}", where=where)
        tcp = self.transport == "tcp"
        self._address = ServerAddress(transport=self.transport, host=self.host if tcp else None,
                                      port=self.port if tcp else client_port,
                                      profile=self.profile.name,
                                      device_ids={a: self.profile.device_ids[a] for a in self.axes},
                                      baudrate=None if tcp else self.baudrate)
        log.info("simulated %s controller serving %s", self.profile.name, self._address.as_dict())
        return self._address

    def stop(self) -> None:
        """Close connections and the listener, stop the thread (and the pty bridge)."""
        if self._thread is not None:
            if self._loop is not None and self._stop_event is not None:
                self._loop.call_soon_threadsafe(self._stop_event.set)
            self._thread.join(timeout=5.0)
            if self._thread.is_alive():
                log.warning("sim %s: server thread did not stop within 5 s", self.profile.name)
            self._thread = None
        if self._bridge is not None:
            self._bridge.stop()
            self._bridge = None
        self._address = None

    def __enter__(self) -> ModbusSimServer:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    @property
    def address(self) -> ServerAddress:
        if self._address is None:
            raise RuntimeError("sim server is not running")
        return self._address

    @property
    def bridge(self) -> PtyBridge | None:
        return self._bridge

    # ---- the server thread

    def _run(self, listen_on: str) -> None:
        leave_interrupts_to_the_main_thread()
        loop = asyncio.new_event_loop()
        self._loop = loop
        try:
            loop.run_until_complete(self._serve(listen_on))
        except BaseException as exc:  # reported to start(); the thread must not die silently
            self._failure = exc
            self._ready.set()
        finally:
            pending = asyncio.all_tasks(loop)
            for task in pending:
                task.cancel()
            if pending:
                loop.run_until_complete(asyncio.gather(*pending, return_exceptions=True))
            loop.close()
            self._loop = None

    async def _serve(self, listen_on: str) -> None:
        self._stop_event = asyncio.Event()
        devices = [self._sim_device(dev, unit) for dev, unit in self.devices.items()]
        devices.append(self._catch_all_device())
        server: ModbusTcpServer | ModbusSerialServer
        if self.transport == "tcp":
            server = ModbusTcpServer(devices, address=(self.host, self.port),
                                     trace_pdu=answer_identification(self.profile.name))
        else:
            server = ModbusSerialServer(devices, port=listen_on, baudrate=self.baudrate,
                                        bytesize=self.profile.transport.bytesize,
                                        parity=self.profile.transport.parity,
                                        stopbits=self.profile.transport.stopbits,
                                        trace_packet=self._drop_unknown_device_answers,
                                        trace_pdu=answer_identification(self.profile.name))
        await server.serve_forever(background=True)
        if self.transport == "tcp":
            listener = server.transport  # pymodbus keeps its listening asyncio.Server there
            assert isinstance(listener, asyncio.Server), listener
            self.port = listener.sockets[0].getsockname()[1]
        self._ready.set()
        try:
            await self._stop_event.wait()
        finally:
            await server.shutdown()

    def _drop_unknown_device_answers(self, sending: bool, packet: bytes) -> bytes:
        # On an RS-485 line an absent slave is silent; pymodbus would answer for it.
        if sending and packet and packet[0] not in self.devices:
            return b""
        return packet

    # ---- pymodbus device definitions

    def _sim_device(self, device_id: int, unit: _SimulatedAxis) -> SimDevice:
        holding = self._holding_blocks()
        bits = functools.partial(SimData, values=False, datatype=DataType.BITS)
        coils = [bits(s.address, readonly=not s.writable) for s in self.profile.values.values()
                 if s.function == "coil"] or [bits(0)]  # pymodbus needs a coil block
        return SimDevice(device_id, simdata=(coils, [bits(0)], holding,
                                             [SimData(0, datatype=DataType.INVALID)]),
                         action=functools.partial(self._on_request, unit))

    def _holding_blocks(self) -> list[SimData]:
        """One SimData per register, with gaps the client may read across served as zeros."""
        specs = sorted((s for s in self.profile.values.values() if s.function == "holding"),
                       key=lambda s: s.address)
        registers = functools.partial(SimData, values=0, datatype=DataType.REGISTERS)
        blocks: list[SimData] = []
        previous_end: int | None = None
        for spec in specs:
            gap = 0 if previous_end is None else spec.address - previous_end
            if previous_end is not None and 0 < gap <= self.profile.status.max_gap_registers:
                blocks.append(registers(previous_end, count=gap, readonly=True))
            # status words are not writable by the client; writable-only objects read as zero
            blocks.append(registers(spec.address, count=spec.words, readonly=not spec.writable))
            previous_end = spec.address + spec.words
        return blocks

    def _catch_all_device(self) -> SimDevice:
        """Device id 0 in pymodbus terms: answers any unknown id with 'gateway: no response'."""

        async def no_such_device(*_args: object) -> ExcCodes:
            return ExcCodes.GATEWAY_NO_RESPONSE

        # registers must be valid for pymodbus to call the action at all
        return SimDevice(0,
                         simdata=[SimData(0, count=0xFFFF, values=0, datatype=DataType.REGISTERS)],
                         action=no_such_device)

    async def _on_request(self, unit: _SimulatedAxis, function_code: int, start_address: int,
                          address: int, count: int, registers: list[int],
                          set_values: Iterable[int] | Iterable[bool] | None) -> ExcCodes | None:
        if function_code not in self.profile.transport.functions:
            # a drive serving FC 03/08/16 only (MR-JE-C) answers anything else so
            log.info("%s: function %d refused (illegal function)", unit.where, function_code)
            return ExcCodes.ILLEGAL_FUNCTION
        try:
            if set_values is not None:
                if function_code in _COIL_FUNCTIONS:
                    result = unit.write_coils(address, [bool(v) for v in set_values])
                else:
                    result = unit.write_registers(address, [int(v) for v in set_values])
                if result is not None:
                    return result
            unit.refresh()
            self._refresh_temperatures(unit)
            self._copy_out(unit, function_code, start_address, registers)
        except Exception:
            log.exception("%s: simulator failed on function %d at %#06x", unit.where,
                          function_code, address)
            return ExcCodes.DEVICE_FAILURE
        return None

    def _refresh_temperatures(self, unit: _SimulatedAxis) -> None:
        """The profile's temperature registers, on the drive that serves them."""
        spec = self.profile.temperature
        if spec is None or unit.axis != spec.axis:
            return
        now = self.temperatures_c()
        for key in ("ambient", "machine"):
            name = getattr(spec, key)
            if name and key in now:
                unit.put(name, round(now[key] / spec.degc_per_count))

    @staticmethod
    def _copy_out(unit: _SimulatedAxis, function_code: int, start: int,
                  registers: list[int]) -> None:
        """Copy the device state into pymodbus's block (registers, or coils packed 16 a word)."""
        size = len(registers)
        if function_code in _COIL_FUNCTIONS:
            for address, state in unit.memory.coils.items():
                index, bit = address // 16 - start, address % 16
                if 0 <= index < size:
                    registers[index] = ((registers[index] | 1 << bit) if state
                                        else (registers[index] & ~(1 << bit)))
            return
        for address, word in unit.memory.holding.items():
            if 0 <= address - start < size:
                registers[address - start] = word
