"""Drive emulators written from the makers' manuals on modbus_tk, not on pymodbus.

Nothing here imports the project's profiles, codec or simulator: addresses,
word order and behaviour are written out again from the manuals, so that the
client is checked against an implementation that does not share its mistakes.

- :class:`IaiDrive`, IAI ROBO Cylinder PCON over Modbus (IAI ME0162): coils SON
  0x0403, ALRS 0x0407 (the reset happens on the change back to 0000), STP
  0x040A (pause; releasing it resumes the remaining distance), HOME 0x040B
  (0 -> 1), PMSL 0x0427, STOP 0x042C (deceleration stop: cancels the move; the
  coil reads 0 again); registers 0x9000.. (PNOW s32 high word first, ALMC,
  DSS1 0x9005: bit 15 EMGS, 12 SV, 10 ALMH, 4 HEND, 3 PEND; DSSE 0x9007 bit 5
  MOVE), direct move block 0x9900 (9 registers).
- :class:`Cia402Drive`, a CiA 402 drive with objects at their index (MR-JE-C
  style: FC 03/08/16 only when asked, any unit id up to 255): controlword 0x6040,
  statusword 0x6041, modes 0x6060/0x6061, position 0x6064, target 0x607A, home
  offset 0x607C, profile velocity 0x6081, error code 0x603F, store 0x1010, 32-bit
  values low word first. Halt (bit 8) released continues the positioning; quick
  stop (bit 2 low) cancels it and reacts as its quick stop option code (605Ah)
  says: "switch on disabled" (codes 0..4) or "quick stop active" (5..8).
- Either can be power-cycled (``power_cycle``): not homed, counter restarted.

Motion is linear at the commanded speed in real time (no ramps): the tests
keep moves long enough (seconds) that no timing depends on machine load.
"""

from __future__ import annotations

import socket
import struct
import threading
import time
from dataclasses import dataclass
from typing import TypeVar

import serial
from modbus_tk import defines, hooks, modbus_rtu, modbus_tcp
from modbus_tk.exceptions import ModbusError

# ------------------------------------------------------------------ one axis in real time


@dataclass
class _Motion:
    """Linear motion at constant speed, and braking at a constant deceleration;
    counts are the drive's position units."""

    position: float = 0.0
    start: float = 0.0
    target: float = 0.0
    speed: float = 1000.0  # counts/s
    t0: float = 0.0
    moving: bool = False
    paused_target: float | None = None
    braking: float = 0.0  # counts/s^2 while braking to rest, else 0
    direction: int = 0  # of the last motion: +1, -1 (0 before any)
    stopped_at: float = 0.0  # time.monotonic() of the last arrival or stop

    def now(self) -> float:
        if not self.moving:
            return self.position
        elapsed = time.monotonic() - self.t0
        if self.braking:
            t_stop = self.speed / self.braking
            t = min(elapsed, t_stop)
            travelled = self.speed * t - self.braking * t * t / 2.0
            if elapsed >= t_stop:
                self.position = self.start + self.direction * travelled
                self._arrived()
                return self.position
            return self.start + self.direction * travelled
        travelled = self.speed * elapsed
        distance = abs(self.target - self.start)
        if travelled >= distance:
            self.position = self.target
            self._arrived()
            return self.position
        return self.start + (travelled if self.target > self.start else -travelled)

    def _arrived(self) -> None:
        self.moving, self.braking, self.stopped_at = False, 0.0, time.monotonic()

    def go(self, target: float, speed: float) -> None:
        self.position = self.now()
        self.start, self.target, self.speed = self.position, target, max(speed, 1.0)
        self.t0, self.moving, self.paused_target, self.braking = \
            time.monotonic(), True, None, 0.0
        if target != self.position:
            self.direction = 1 if target > self.position else -1

    def brake(self, deceleration: float) -> None:
        """Slow down to rest at ``deceleration`` counts/s^2 (a ramp, not a jump)."""
        self.position = self.now()
        self.paused_target = None
        if not self.moving or self.braking:
            return
        self.start, self.t0, self.braking = self.position, time.monotonic(), deceleration

    def halt(self) -> None:
        self.position = self.now()
        if self.moving:
            self._arrived()

    def pause(self) -> None:
        if self.moving:
            self.paused_target = self.target
        self.halt()

    def resume(self) -> None:
        target, self.paused_target = self.paused_target, None
        if target is not None:
            self.go(target, self.speed)

    def cancel(self) -> None:
        self.halt()
        self.paused_target = None


def _s32_words(value: int, high_first: bool) -> list[int]:
    raw = value & 0xFFFFFFFF
    words = [raw >> 16, raw & 0xFFFF]
    return words if high_first else words[::-1]


def _s32(words: list[int], high_first: bool) -> int:
    high, low = (words[0], words[1]) if high_first else (words[1], words[0])
    raw = (high << 16) | low
    return raw - (1 << 32) if raw & 0x80000000 else raw


# ------------------------------------------------------------------ servers and dispatch

_EMULATED: dict[int, _Drive] = {}  # id(modbus_tk slave) -> drive
_HOOK_LOCK = threading.Lock()


def _on_request(args: tuple) -> bytes | None:
    slave, pdu = args
    drive = _EMULATED.get(id(slave))
    return None if drive is None else drive.handle(slave, pdu)


class _Drive:
    """One Modbus device (one axis) in a modbus_tk slave."""

    functions: tuple[int, ...] = ()

    def __init__(self, slave) -> None:  # type: ignore[no-untyped-def]
        self.slave = slave
        self.motion = _Motion()
        self.requests: list[bytes] = []  # every request PDU, as received
        self.lock = threading.RLock()
        self.powered = True
        #: The next this many requests are answered exception 6, "server device busy",
        #: and not executed (Modbus Application Protocol V1.1b3 §7).
        self.busy_replies = 0

    def power_off(self) -> None:
        """Switched off: a request still on its way (sent before the line was cut)
        finds no drive to act on it; ``power_cycle`` switches it on again."""
        with self.lock:
            self.motion.cancel()  # no power, no motion
            self.powered = False

    def handle(self, slave, pdu: bytes) -> bytes:  # type: ignore[no-untyped-def]
        with self.lock:
            if not self.powered:  # nobody answers; the reply goes nowhere
                return bytes([pdu[0] | 0x80, defines.SLAVE_DEVICE_FAILURE])
            self.requests.append(bytes(pdu))
            fc = pdu[0]
            if self.busy_replies > 0:
                self.busy_replies -= 1
                return bytes([fc | 0x80, defines.SLAVE_DEVICE_BUSY])
            if fc not in self.functions:
                return bytes([fc | 0x80, defines.ILLEGAL_FUNCTION])
            if fc == 8:  # diagnostics, sub-function 0: return query data (echo)
                return bytes(pdu)
            old_coils, old_regs = self._coils(), self._regs()
            self.refresh()
            try:
                reply = slave._fn_code_map[fc](pdu)
            except ModbusError as exc:
                return bytes([fc | 0x80, exc.get_exception_code()])
            if fc in (5, 15):
                address = struct.unpack(">H", pdu[1:3])[0]
                self.on_coils(old_coils, address)
            elif fc in (6, 16):
                address = struct.unpack(">H", pdu[1:3])[0]
                count = 1 if fc == 6 else struct.unpack(">H", pdu[3:5])[0]
                error = self.on_registers(old_regs, address, count)
                if error:
                    return bytes([fc | 0x80, error])
            self.refresh()
            return bytes([fc]) + reply

    # memory helpers
    def _coils(self) -> dict[int, int]:
        return {}

    def _regs(self) -> dict[int, int]:
        return {}

    def get(self, block: str, address: int, count: int = 1) -> list[int]:
        return list(self.slave.get_values(block, address, count))

    def set(self, block: str, address: int, values: list[int]) -> None:
        self.slave.set_values(block, address, values)

    def refresh(self) -> None: ...

    def on_coils(self, old: dict[int, int], address: int) -> None: ...

    def on_registers(self, old: dict[int, int], address: int, count: int) -> int | None:
        return None


class IaiDrive(_Drive):
    """IAI PCON by ME0162 (see the module docstring)."""

    functions = (1, 3, 5, 6, 15, 16)
    SON, ALRS, STP, HOME, PMSL, STOP = 0x0403, 0x0407, 0x040A, 0x040B, 0x0427, 0x042C

    def __init__(self, slave) -> None:  # type: ignore[no-untyped-def]
        super().__init__(slave)
        slave.add_block("coils", defines.COILS, 0x0400, 0x30)
        slave.add_block("status", defines.HOLDING_REGISTERS, 0x9000, 0x10)
        slave.add_block("move", defines.HOLDING_REGISTERS, 0x9900, 9)
        self.servo = self.homed = False
        self.alarm = 0
        self.homing = False
        self.reference = 0.0  # PNOW = physical - reference (0 once homed)
        self.events: list[tuple[int, str]] = []

    def physical_counts(self) -> float:
        return self.motion.now() + self.reference

    def power_cycle(self, counter_at_power_on: int = 0) -> None:
        """Switched off and on: servo off, HEND clear (an incremental encoder counts
        from where it stands) [ME0162 DSS1 HEND]."""
        with self.lock:
            physical = self.physical_counts()
            self.motion.cancel()
            self.motion.position = float(counter_at_power_on)
            self.reference = physical - counter_at_power_on
            self.servo = self.homed = self.homing = False
            self.alarm = 0
            self.powered = True
            self.events.append((len(self.requests), "power cycle"))
            self.refresh()

    def coil(self, address: int) -> int:
        return self.get("coils", address)[0]

    def _coils(self) -> dict[int, int]:
        return dict(zip(range(0x0400, 0x0430), self.get("coils", 0x0400, 0x30), strict=True))

    def on_coils(self, old: dict[int, int], address: int) -> None:
        new = self.coil(address)
        was = old[address]
        if address == self.SON and self.coil(self.PMSL):
            self.servo = bool(new)
            if not new:
                self.motion.cancel()
        elif address == self.ALRS and was and not new:
            self.alarm = 0  # the reset happens on the change back to 0000
        elif address == self.STP and new and not was:
            self.motion.pause()
        elif address == self.STP and was and not new:
            self.motion.resume()  # releasing STP resumes the remaining distance
        elif address == self.STOP and new:
            self.motion.cancel()
            self.homing = False
            self.set("coils", self.STOP, [0])
        elif address == self.HOME and new and not was and self.servo and not self.alarm \
                and self.coil(self.PMSL) and not self.coil(self.STP):
            self.homed, self.homing = False, True
            self.motion.go(-self.reference, 5000.0)

    def on_registers(self, old: dict[int, int], address: int, count: int) -> int | None:
        if address != 0x9900:
            return None
        if not (self.servo and self.coil(self.PMSL)) or self.alarm or self.coil(self.STP):
            return None  # ignored, as the controller ignores a move it cannot make
        block = self.get("move", 0x9900, 9)
        target = _s32(block[0:2], True)
        speed = _s32(block[4:6], True)
        if not -10000 <= target <= 6000:  # its soft limits, 0.01 mm
            self.alarm = 0x0A7
            self.motion.cancel()
            return None
        self.motion.go(float(target), float(speed))
        return None

    def refresh(self) -> None:
        position = round(self.motion.now())
        if self.homing and not self.motion.moving:
            self.homing, self.homed = False, True
            self.motion.position = self.reference = 0.0
            position = 0
            self.events.append((len(self.requests), "homed"))
        dss1 = (self.servo << 12) | ((self.alarm != 0) << 10) | (self.homed << 4) \
            | ((self.servo and not self.motion.moving) << 3)
        dsse = self.motion.moving << 5
        self.set("status", 0x9000, [*_s32_words(position, True), self.alarm, 0, 0, dss1, 0,
                                    dsse])


class Cia402Drive(_Drive):
    """A CiA 402 drive, objects at their index, low word first (see the module docstring).

    The device state machine is CiA 402-2's (IEC 61800-7-201), written from its
    command coding: controlword bits 7, 3..0 select disable voltage (transitions 7,
    9, 10, 12), quick stop (7, 10, 11), shutdown (2, 6, 8), switch on / disable
    operation (3, 5), enable operation (4, 16) and fault reset (15, on the rising
    edge of bit 7). The quick stop's reaction follows object 605Ah, the quick stop
    option code: 0 disables the drive function at once; 1 to 4 slow down (on the
    slow-down ramp, the quick stop ramp, the current limit, the voltage limit) and
    then pass to "switch on disabled"; 5 to 8 slow down the same four ways and stay
    in "quick stop active", from which "enable operation" (transition 16) or
    "disable voltage" (12) leads out. Statusword bit 5 (quick stop) is 0 in
    "quick stop active" and 1 in the states of operation [CiA 402 state coding].

    :meth:`power_cycle` is a drive switched off and on: incremental encoder, so its
    counter reads ``counter_at_power_on`` wherever the axis stands and the drive is
    not homed; RAM parameters (home offset) come back from its non-volatile memory.
    """

    OBJECTS = {0x1000: 2, 0x1010: 2, 0x603F: 1, 0x6040: 1, 0x6041: 1, 0x6060: 1, 0x6061: 1,
               0x6064: 2, 0x607A: 2, 0x607C: 2, 0x6081: 2}

    #: Kinco FD's Modbus addresses of the objects it maps (Kinco FD servo driver user
    #: manual, Modbus address table; 0x3100/0x3200 in the FD3/CD3 manual's §12.3 example
    #: frames, the others recalled, as in kinco-fd.toml). Objects it leaves out are not
    #: served. Kinco sends 32-bit values low word first (the same §12.3 FC 0x10 example)
    #: and takes speeds in DEC (``speed_in_dec``).
    KINCO = {0x6040: 0x3100, 0x6041: 0x3200, 0x6060: 0x3500, 0x6064: 0x3700,
             0x607A: 0x4000, 0x6081: 0x4A00}

    #: CiA 301 1000h device type: device profile number 402 (0x0192) in bits 0-15,
    #: drive type 02h (servo drive) in bits 16-23 [CiA 402-2 device type]
    DEVICE_TYPE = 0x0002_0192

    STATUS = {"switch_on_disabled": 0x0040, "ready_to_switch_on": 0x0021,
              "switched_on": 0x0023, "operation_enabled": 0x0027,
              "quick_stop_active": 0x0007, "fault": 0x0008}

    def __init__(self, slave, *, functions: tuple[int, ...] = (3, 6, 16),  # type: ignore[no-untyped-def]
                 home_sign: int = -1, addresses: dict[int, int] | None = None,
                 high_first: bool = False, quick_stop_option_code: int = 2,
                 speed_in_dec: bool = False) -> None:
        super().__init__(slave)
        self.functions = functions
        self.home_sign = home_sign  # position at the home point = home_sign × home offset
        self.high_first = high_first
        # Kinco FD5/FD5P object tables: DEC = RPM × 512 × R / 1875 (R increments per
        # revolution), so 1 increment/s is 512 × 60 / 1875 DEC whatever R
        self.counts_per_s_per_speed_unit = 1875 / (512 * 60) if speed_in_dec else 1.0
        # object index -> Modbus address (at the index, unless the drive maps them elsewhere)
        self.at = dict(addresses) if addresses else {i: i for i in self.OBJECTS}
        for index, address in self.at.items():
            slave.add_block(f"{index:04x}", defines.HOLDING_REGISTERS, address,
                            self.OBJECTS[index])
        self.quick_stop_option_code = quick_stop_option_code  # 605Ah, set on the drive
        self.slow_down_ramp = 20_000.0   # counts/s^2: profile deceleration 6084h
        self.quick_stop_ramp = 200_000.0  # counts/s^2: quick stop deceleration 6085h
        self.limit_ramp = 1_000_000.0     # counts/s^2: braking at the current / voltage limit
        self.state = "switch_on_disabled"
        self.cw = 0
        self.reference = 0.0  # position counter = physical - reference
        self.homed_flag = False
        self.homing = False
        self.ack = False
        self.error = 0
        self.saves = 0
        self.saved_home_offset = 0  # what the non-volatile memory holds for 607Ch
        self.quick_stop_at: float | None = None
        # software position limits 607Dh, counts (None: the drive has none set)
        self.limits: tuple[int, int] | None = (-10200, 6200)
        self.events: list[tuple[int, str]] = []  # (requests received so far, what happened)
        self.put(0x6060, 1)
        self.put(0x1000, self.DEVICE_TYPE)

    # ---------------------------------------------------------------- memory
    def obj(self, index: int) -> int:
        if index not in self.at:
            return 0
        words = self.get(f"{index:04x}", self.at[index], self.OBJECTS[index])
        return words[0] if len(words) == 1 else _s32(words, self.high_first)

    def put(self, index: int, value: int) -> None:
        if index not in self.at:
            return
        words = [value & 0xFFFF] if self.OBJECTS[index] == 1 else \
            _s32_words(value, self.high_first)
        self.set(f"{index:04x}", self.at[index], words)

    def physical_counts(self) -> float:
        """Where the axis is, in counts from its home switch (what a ruler would show)."""
        return self.motion.now() + self.reference

    def note(self, what: str) -> None:
        self.events.append((len(self.requests), what))

    # ---------------------------------------------------------------- power
    def power_cycle(self, counter_at_power_on: int = 0) -> None:
        """Switched off where it stands and on again (see the class docstring)."""
        with self.lock:
            physical = self.physical_counts()
            self.motion.cancel()  # no power, no motion (the axis coasts to rest: here at once)
            self.motion.position = float(counter_at_power_on)
            self.reference = physical - counter_at_power_on
            self.state, self.cw, self.ack, self.error = "switch_on_disabled", 0, False, 0
            self.homing = self.homed_flag = False
            self.powered = True
            self.put(0x607C, self.saved_home_offset)
            self.put(0x6060, 0)  # no mode until the master chooses one
            self.note("power cycle")
            self.refresh()

    # ---------------------------------------------------------------- requests
    def on_registers(self, old: dict[int, int], address: int, count: int) -> int | None:
        if 0x1010 in self.at and address == self.at[0x1010]:
            signature = self.obj(0x1010) & 0xFFFFFFFF
            self.put(0x1010, 0)
            if signature != 0x65766173:  # "save"
                return defines.ILLEGAL_DATA_VALUE
            self.saves += 1
            self.saved_home_offset = self.obj(0x607C)
        if address == self.at[0x6040]:
            self._controlword(self.obj(0x6040))
        return None

    def _command(self, cw: int) -> str:
        """The device control command the controlword codes [CiA 402 command coding]."""
        if not cw & 0x02:
            return "disable_voltage"
        if not cw & 0x04:
            return "quick_stop"
        if not cw & 0x01:
            return "shutdown"
        return "enable_operation" if cw & 0x08 else "switch_on"

    def _controlword(self, cw: int) -> None:
        old, self.cw = self.cw, cw
        rising, falling = cw & ~old, old & ~cw
        if self.state == "fault":
            if rising & 0x80:  # transition 15
                self.state, self.error = "switch_on_disabled", 0
                self.note("fault reset")
            return
        command, state = self._command(cw), self.state
        if state == "switch_on_disabled":
            if command == "shutdown":
                self.state = "ready_to_switch_on"  # 2
        elif state == "ready_to_switch_on":
            if command in ("disable_voltage", "quick_stop"):
                self.state = "switch_on_disabled"  # 7
            elif command in ("switch_on", "enable_operation"):
                self.state = "switched_on"  # 3
        elif state == "switched_on":
            if command in ("disable_voltage", "quick_stop"):
                self.state = "switch_on_disabled"  # 10
            elif command == "shutdown":
                self.state = "ready_to_switch_on"  # 6
        elif state == "operation_enabled":
            if command == "disable_voltage":
                self._power_off("switch_on_disabled")  # 9
            elif command == "shutdown":
                self._power_off("ready_to_switch_on")  # 8
            elif command == "switch_on":
                self.motion.brake(self.slow_down_ramp)  # 5, disable operation
                self.state = "switched_on"
            elif command == "quick_stop":
                self._quick_stop()  # 11
        elif state == "quick_stop_active":
            if command == "disable_voltage":
                self._power_off("switch_on_disabled")  # 12
            elif command == "enable_operation" and self.quick_stop_option_code in (5, 6, 7, 8) \
                    and not self.motion.moving:
                self.state = "operation_enabled"  # 16
        if self.state == "switched_on" and command == "enable_operation":
            self.state = "operation_enabled"  # 4 (after 3: "switch on + enable operation")
        if self.state != "operation_enabled":
            self.ack = False
            return
        self._operate(cw, rising, falling)

    def _power_off(self, state: str) -> None:
        """The power stage switched off: the motor no longer holds or drives the axis."""
        self.motion.cancel()
        self.homing = False
        self.state = state

    def _quick_stop(self) -> None:
        """Transition 11 and the reaction 605Ah asks for."""
        code = self.quick_stop_option_code
        self.note(f"quick stop (option code {code})")
        self.quick_stop_at = self.motion.now()  # counts, where the stop began
        self.homing = False
        self.motion.paused_target = None
        if code == 0:  # disable drive function: the power stage off at once
            self._power_off("switch_on_disabled")
            return
        ramp = {1: self.slow_down_ramp, 2: self.quick_stop_ramp, 3: self.limit_ramp,
                4: self.limit_ramp}[(code - 1) % 4 + 1]
        self.motion.brake(ramp)
        self.state = "quick_stop_active"

    def _operate(self, cw: int, rising: int, falling: int) -> None:
        mode = self.obj(0x6060)
        if rising & 0x100:
            self.motion.pause()
        elif falling & 0x100 and mode == 1:
            self.motion.resume()  # profile position: halt = 0 continues the positioning
        if falling & 0x10:
            self.ack = False
        if rising & 0x10 and not cw & 0x100:
            if mode == 6:
                self.homing, self.homed_flag = True, False
                self.note("homing started")
                self.motion.go(self._physical_zero(), 5000.0)
            elif mode == 1:
                target = self.obj(0x607A)
                self.note(f"set-point {target}")
                if self.limits is not None and not self.limits[0] <= target <= self.limits[1]:
                    self.state, self.error = "fault", 0x8612
                    self.motion.cancel()
                    return
                self.motion.go(float(target),
                               self.obj(0x6081) * self.counts_per_s_per_speed_unit)
                self.ack = True

    def _physical_zero(self) -> float:
        """The counter value of the home switch, where homing goes."""
        return -self.reference

    def refresh(self) -> None:
        position = self.motion.now()
        if self.homing and not self.motion.moving:
            # homed: the counter at the home point becomes home_sign × home offset
            self.homing, self.homed_flag = False, True
            at_home = self.home_sign * self.obj(0x607C)
            self.reference += position - at_home
            self.motion.position = position = float(at_home)
            self.note("homed")
        if self.state == "quick_stop_active" and not self.motion.moving \
                and self.quick_stop_option_code in (1, 2, 3, 4):
            self.state = "switch_on_disabled"  # 12, once the drive stands
        sw = self.STATUS[self.state] | 0x0200
        if not self.motion.moving:
            sw |= 0x0400  # target reached (in quick stop active: the drive stands)
        mode = self.obj(0x6060)
        if (mode == 6 and self.homed_flag and not self.homing) or (mode == 1 and self.ack):
            sw |= 0x1000
        self.put(0x6041, sw)
        self.put(0x6061, mode)
        self.put(0x6064, round(position))
        self.put(0x603F, self.error)


DriveT = TypeVar("DriveT", bound=_Drive)


class EmulatorServer:
    """A modbus_tk server (TCP on 127.0.0.1, or RTU on a serial device) for some drives."""

    def __init__(self, transport: str, *, serial_path: str = "", baudrate: int = 38400) -> None:
        if transport == "tcp":
            self.server = modbus_tcp.TcpServer(port=0, address="127.0.0.1")
        else:
            self._serial = serial.Serial(serial_path, baudrate=baudrate)
            self.server = modbus_rtu.RtuServer(self._serial)
        self.transport = transport
        self.drives: dict[int, _Drive] = {}

    def add(self, unit: int, kind: type[DriveT], **options: object) -> DriveT:
        drive = kind(self.server.add_slave(unit), **options)  # type: ignore[arg-type]
        self.drives[unit] = drive
        with _HOOK_LOCK:
            if not _EMULATED:
                hooks.install_hook("modbus.Slave.handle_request", _on_request)
            _EMULATED[id(drive.slave)] = drive
        return drive

    def start(self) -> int | None:
        """Serve; returns the TCP port (None over RTU)."""
        self.server.start()
        if self.transport != "tcp":
            return None
        deadline = time.monotonic() + 5.0
        while not self.server._sockets:
            if time.monotonic() > deadline:
                raise RuntimeError("modbus_tk server did not listen")
            time.sleep(0.01)
        sock: socket.socket = self.server._sockets[0]
        return int(sock.getsockname()[1])

    def stop(self) -> None:
        self.server.stop()
        with _HOOK_LOCK:
            for drive in self.drives.values():
                _EMULATED.pop(id(drive.slave), None)
            if not _EMULATED:
                hooks.uninstall_hook("modbus.Slave.handle_request", _on_request)
        if self.transport != "tcp":
            self._serial.close()
