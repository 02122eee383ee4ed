"""What a gauge protocol's backend must carry, checked part by part: the tests of the
table run it on every protocol, and on the throwaway protocol of test_new_protocol."""

from __future__ import annotations

import inspect
from typing import Any

from ogacq_drivers.indicators.backend import Backend, Codec, load
from ogacq_drivers.sim.gauges import SerialDevice, SimulatedGauge

INDICATOR_METHODS = ("read", "flush_input", "close")  # the Indicator protocol's methods


def missing_parts(name: str, entry: Backend) -> list[str]:
    """What ``entry`` lacks or gets wrong, one line each; [] for a whole backend."""
    problems: list[str] = []

    def part(what: str, dotted: str) -> Any:
        try:
            return load(dotted)
        except Exception as exc:
            problems.append(f"{name}: its {what} {dotted!r} does not load ({exc!r})")
            return None

    driver = part("driver", entry.driver)
    if driver is not None:
        problems += _driver_problems(name, entry, driver)
    codec = part("codec", entry.codec)
    if codec is not None and not isinstance(codec, Codec):
        problems.append(f"{name}: its codec is a {type(codec).__name__}, not a Codec")
    simulator = part("simulator", entry.simulator)
    if simulator is not None:
        problems += _simulator_problems(name, entry, simulator)
    if entry.hints.find:
        find = part("hints.find", entry.hints.find)
        if find is not None and not callable(find):
            problems.append(f"{name}: hints.find names no function")
    if bool(entry.hints.channel) != bool(entry.same_indicator):
        problems.append(f"{name}: hints.channel and same_indicator go together (a protocol "
                        "with channels says which of them reach one indicator)")
    elif entry.same_indicator:
        same = part("same_indicator", entry.same_indicator)
        if same is not None and not callable(same):
            problems.append(f"{name}: same_indicator names no function")
    return problems


def _driver_problems(name: str, entry: Backend, driver: Any) -> list[str]:
    if not inspect.isclass(driver):
        return [f"{name}: its driver is not a class"]
    problems = [f"{name}: its driver has no {m}()" for m in INDICATOR_METHODS
                if not callable(getattr(driver, m, None))]
    try:
        if entry.serial:  # built on the link the station opens
            inspect.signature(driver).bind(object(), where="w", unit="mm", owns_link=True)
        else:  # opens its own device from the port
            opener = getattr(driver, "open", None)
            if opener is None:
                raise AttributeError("it has no open() class method")
            inspect.signature(opener).bind("port", where="w", unit="mm")
    except (TypeError, AttributeError) as exc:
        problems.append(f"{name}: its driver cannot be opened as a {entry.kind} one ({exc})")
    return problems


def _simulator_problems(name: str, entry: Backend, simulator: Any) -> list[str]:
    if not callable(getattr(simulator, "simulate", None)):
        return [f"{name}: its simulator has no simulate()"]
    if entry.serial:
        if not (isinstance(simulator, type) and issubclass(simulator, SerialDevice)):
            return [f"{name}: a serial protocol's simulator is a SerialDevice"]
        if not isinstance(getattr(simulator, "MAX_DECIMALS", None), int):
            return [f"{name}: its simulated device does not say how many decimals it shows"]
    elif not (isinstance(simulator, type) and issubclass(simulator, SimulatedGauge)):
        return [f"{name}: its simulator is not a SimulatedGauge"]
    return []
