"""Issue 35.8: every error the tool reports to a user is an ``OgacqError``, so that the
command line says it in one line with its exit code wherever it is raised. A table
that does not fit its format (``TableError``), a record the history cannot hold
(``RecordError``) and a plan no campaign can run (``PlanError``, the 13 ValueErrors
of protocol/plan.py each caller wrapped) were ValueErrors outside the root."""

from __future__ import annotations

import importlib
import inspect
import pkgutil

import pytest

import ogacq_drivers
import ogacq
from ogacq.errors import InputError, OgacqError
from ogacq.history.entries import check_record
from ogacq.model.machine import PAPER_PROTOTYPE
from ogacq.protocol.plan import ProtocolConfig, check_postures

# raised and caught inside one module, never reported: the simulated USB gauge's
# stalled endpoint; a calibration round that writes nothing (its end, not an error)
INTERNAL = {"ogacq_drivers.sim.usb_itn._Stall", "ogacq.calibration.procedure.Stopped"}


def defined_exceptions() -> set[str]:
    found = set()
    for package in (ogacq, ogacq_drivers):
        for info in pkgutil.walk_packages(package.__path__, f"{package.__name__}."):
            if info.name.endswith("__main__"):
                continue
            module = importlib.import_module(info.name)
            found |= {f"{module.__name__}.{name}" for name, value in vars(module).items()
                      if inspect.isclass(value) and issubclass(value, BaseException)
                      and value.__module__ == module.__name__
                      and not issubclass(value, OgacqError)}
    return found


def test_every_exception_the_tool_defines_is_under_the_root():
    assert defined_exceptions() == INTERNAL


def a_table_error() -> Exception:
    from ogacq.compensation.linuxcnc import triplets
    from ogacq.model.axis_map import AxisMap

    flat = AxisMap("x", (0.0, 10.0), (0.0, 0.001), (0.0, 0.001), (0.0, 0.0), (0.0, 0.0))
    try:
        triplets(flat, file_type=7)
    except Exception as exc:
        return exc
    raise AssertionError("no error")


def a_record_error() -> Exception:
    try:
        check_record({"format": "something-else/1"})
    except Exception as exc:
        return exc
    raise AssertionError("no error")


def a_plan_error() -> Exception:
    try:
        check_postures(ProtocolConfig(postures=("zero", 999.0)), PAPER_PROTOTYPE)
    except Exception as exc:
        return exc
    raise AssertionError("no error")


@pytest.mark.parametrize("raised", [a_table_error, a_record_error, a_plan_error])
def test_a_table_a_record_and_a_plan_that_cannot_be_are_input_errors(raised):
    error = raised()
    assert isinstance(error, InputError) and error.exit_code == 2, type(error).__mro__
    assert "\n" not in str(error) and str(error)
