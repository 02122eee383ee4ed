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
  stop (bit 2 low) cancels it and ends in "switch on disabled".

Motion is linear at the commanded speed in real time (no ramps): the tests
keep moves long enough (seconds) that no timing depends on machine load.
"""

from __future__ import annotations

import socket
import struct
import threading
import time
from dataclasses import dataclass

import serial
from modbus_tk import defines, hooks, modbus_rtu, modbus_tcp
from modbus_tk.exceptions import ModbusError

# ------------------------------------------------------------------ one axis in real time


@dataclass
class _Motion:
    """Linear motion at constant speed; counts are the drive's position units."""

    position: float = 0.0
    start: float = 0.0
    target: float = 0.0
    speed: float = 1000.0  # counts/s
    t0: float = 0.0
    moving: bool = False
    paused_target: float | None = None

    def now(self) -> float:
        if not self.moving:
            return self.position
        travelled = self.speed * (time.monotonic() - self.t0)
        distance = abs(self.target - self.start)
        if travelled >= distance:
            self.position, self.moving = self.target, False
            return self.position
        return self.start + (travelled if self.target > self.start else -travelled)

    def go(self, target: float, speed: float) -> None:
        self.position = self.now()
        self.start, self.target, self.speed = self.position, target, max(speed, 1.0)
        self.t0, self.moving, self.paused_target = time.monotonic(), True, None

    def halt(self) -> None:
        self.position, self.moving = self.now(), False

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

    def handle(self, slave, pdu: bytes) -> bytes:  # type: ignore[no-untyped-def]
        with self.lock:
            self.requests.append(bytes(pdu))
            fc = pdu[0]
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
            self.motion.go(0.0, 5000.0)

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
        dss1 = (self.servo << 12) | ((self.alarm != 0) << 10) | (self.homed << 4) \
            | ((self.servo and not self.motion.moving) << 3)
        dsse = self.motion.moving << 5
        self.set("status", 0x9000, [*_s32_words(position, True), self.alarm, 0, 0, dss1, 0,
                                    dsse])


class Cia402Drive(_Drive):
    """A CiA 402 drive, objects at their index, low word first (see the module docstring)."""

    OBJECTS = {0x1010: 2, 0x603F: 1, 0x6040: 1, 0x6041: 1, 0x6060: 1, 0x6061: 1, 0x6064: 2,
               0x607A: 2, 0x607C: 2, 0x6081: 2}

    #: Kinco FD's Modbus addresses of the objects it maps (Kinco FD servo driver user
    #: manual, Modbus address table; 0x3100/0x3200 quoted in issue 11, the others
    #: recalled, as in kinco-fd.toml). Objects it leaves out are not served.
    KINCO = {0x6040: 0x3100, 0x6041: 0x3200, 0x6060: 0x3500, 0x6064: 0x3700,
             0x607A: 0x4000, 0x6081: 0x4A00}

    def __init__(self, slave, *, functions: tuple[int, ...] = (3, 6, 16),  # type: ignore[no-untyped-def]
                 home_sign: int = -1, addresses: dict[int, int] | None = None,
                 high_first: bool = False) -> None:
        super().__init__(slave)
        self.functions = functions
        self.home_sign = home_sign  # position at the home point = home_sign × home offset
        self.high_first = high_first
        # object index -> Modbus address (at the index, unless the drive maps them elsewhere)
        self.at = dict(addresses) if addresses else {i: i for i in self.OBJECTS}
        for index, address in self.at.items():
            slave.add_block(f"{index:04x}", defines.HOLDING_REGISTERS, address,
                            self.OBJECTS[index])
        self.state = "switch_on_disabled"
        self.cw = 0
        self.reference = 0.0  # position counter = physical - reference
        self.homed_flag = False
        self.homing = False
        self.ack = False
        self.error = 0
        self.saves = 0
        self.put(0x6060, 1)

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

    def on_registers(self, old: dict[int, int], address: int, count: int) -> int | None:
        if 0x1010 in self.at and address == self.at[0x1010]:
            signature = self.obj(0x1010) & 0xFFFFFFFF
            self.put(0x1010, 0)
            if signature != 0x65766173:  # "save"
                return defines.ILLEGAL_DATA_VALUE
            self.saves += 1
        if address == self.at[0x6040]:
            self._controlword(self.obj(0x6040))
        return None

    def _controlword(self, cw: int) -> None:
        old, self.cw = self.cw, cw
        rising, falling = cw & ~old, old & ~cw
        if self.state == "fault":
            if rising & 0x80:
                self.state, self.error = "switch_on_disabled", 0
            return
        if not cw & 0x02 or not cw & 0x04:  # disable voltage, quick stop (option code 2)
            self.motion.cancel()
            self.homing = False
            self.state = "switch_on_disabled"
        elif not cw & 0x01:
            self.state = "ready_to_switch_on"
            self.motion.cancel()
        elif not cw & 0x08:
            if self.state != "switch_on_disabled":
                self.state = "switched_on"
            self.motion.cancel()
        elif self.state in ("ready_to_switch_on", "switched_on", "operation_enabled"):
            self.state = "operation_enabled"
        if self.state != "operation_enabled":
            self.ack = False
            return
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
                self.motion.go(self._physical_zero(), 5000.0)
            elif mode == 1:
                target = self.obj(0x607A)
                if not -10200 <= target <= 6200:
                    self.state, self.error = "fault", 0x8612
                    self.motion.cancel()
                    return
                self.motion.go(float(target), float(self.obj(0x6081)))
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
        words = {"switch_on_disabled": 0x0040, "ready_to_switch_on": 0x0021,
                 "switched_on": 0x0023, "operation_enabled": 0x0027, "fault": 0x0008}
        sw = words[self.state] | 0x0200
        if not self.motion.moving:
            sw |= 0x0400  # target reached
        mode = self.obj(0x6060)
        if (mode == 6 and self.homed_flag and not self.homing) or (mode == 1 and self.ack):
            sw |= 0x1000
        self.put(0x6041, sw)
        self.put(0x6061, mode)
        self.put(0x6064, round(position))
        self.put(0x603F, self.error)


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

    def add(self, unit: int, kind: type[_Drive], **options: object) -> _Drive:
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
