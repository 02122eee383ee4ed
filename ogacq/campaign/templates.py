"""Commented starting points for the files a user writes: a machine file and a
campaign file, written through their schemas' writers so that a template always
loads back (``ogacq init``; the copies in ``ogacq/examples/`` are these texts)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

from ogacq.campaign.campaign_file import Campaign, ControllerSpec, GaugeSpec, campaign_text
from ogacq.io.machine_file import machine_text
from ogacq.model.gauges import GAUGE_KEYS
from ogacq.model.machine import PAPER_PROTOTYPE
from ogacq.protocol.plan import ProtocolConfig

FORMATS_DOC = "docs/formats.md"

MACHINE_HEADER = f"""\
A machine file: the geometry and the gauges of one Orthoglide-type machine
(format: {FORMATS_DOC} in the ogacq repository). Lengths in mm.
The values below are the papers' prototype: replace them with your machine's.

leg_length_mm           length of the parallelogram legs
rho_min_mm, rho_max_mm  the joint (actuator) travel used by the postures min and max,
                        from the zero posture; rho_min_mm < 0 < rho_max_mm
gauge_resolution_mm     the step the gauges display (0.01 dial, 0.001 digital)
gauge_repeatability_mm  optional: the gauges' scatter when it is known; left out,
                        it is measured from the repeated readings
Optional, shown commented at the end: the machine's name (default: this file's name)
and serial number, its legs' expansion coefficient (steel 11.5 ppm/K when left out),
the tolerances the deviations are accepted against, and each axis's drive: its
ball screw's lead and, where a belt or gear sits between, the travel per motor
revolution (the periods of the screw's and the encoder's cyclic errors, which the
separating scan of `ogacq calibrate` is designed to sample; left out, it samples
every lead from 2 to 40 mm)."""

MACHINE_FOOTER = """name = "OG-1 cell 3"              # recorded in every session and report
serial = "OG-2026-0017"
leg_expansion_ppm_per_k = 11.5    # the legs' linear expansion, 1e-6 /K (steel 11.5)
[tolerances]                      # acceptance of the deviations dx_y+ ... dy_z-
deviation_mm = 0.020              # every deviation within +/- this
"dx_y+" = 0.015                   # a deviation's own tolerance
decision_rule = "guard-band"      # ILAC-G8: guard-band (pass within T - U) or simple
[screws.x]                        # the x axis's drive (the same for y and z)
lead_mm = 5.0                     # the ball screw's lead: mm of travel a screw revolution
revolution_mm = 2.5               # mm a motor (encoder) revolution, if geared or belted"""

CAMPAIGN_HEADER = f"""\
A campaign file: the machine, the station (controller and six gauges) and the
protocol of one unattended calibration, run with `ogacq run THIS_FILE`
(format: {FORMATS_DOC} in the ogacq repository; paths relative to this file).
Replace the controller's and the gauges' ports with your station's; write the
machine file it names with `ogacq init machine`.

deadline_s, [controller] baudrate (RTU), [controller.axes] (one endpoint per axis),
offsets_file (profiles without an offset register), maps_file (the error maps
`ogacq calibrate` writes, applied to every target), tables (the compensation table
formats it writes, e.g. ["linuxcnc", "csv"]; default all), [[gauges]] channel,
serial and baudrate, and a [simulator] table (instead of hardware) may be added.
[axis_scale.x] protocol, port, resolution_mm (and the [[gauges]] identity keys): a
scale along an actuator, for ISO 230-2's positioning test (`ogacq positioning`) and
`ogacq calibrate`'s maps and their validation along the whole travel.

Traceability (recorded in the session; format: docs/formats.md):
operator = "J. Martin"           who runs the calibration
[[gauges]] make, model, serial, certificate, calibrated = 2026-03-01, due = 2027-03-01,
           uncertainty_mm (the certificate's U), uncertainty_k (its k): a gauge past
           its due date is refused before anything moves, unless
[override] expired_gauges = "the reason" (recorded)
[environment] ambient_c = 20.4, machine_c = 21.0 (typed, degC), or
              sensor = "controller" (the profile's temperature registers)"""

CAMPAIGN_NOTES = {
    "gauges": "gauge AXIS_LEG: measures along AXIS on that leg (y_x: along y on the x leg);\n"
              "protocol: how it is read (README, \"Cables and interfaces\"); unit mm or inch",
    "protocol": "postures: zero, max, min or a joint position in mm (or scan_step_mm = 1.0:\n"
                "a scan every 1 mm up and down, scan_from_mm/scan_to_mm its range); approach:\n"
                "sequence, from_below, from_above or both; settle: stable (read once each gauge\n"
                "is at rest against its own noise, at most settle_s; settle_window_s: one period\n"
                "of the slowest ringing covered) or fixed (wait settle_s); times in s",
    "stability": "a reading is taken once `readings` values agree within tolerance_mm",
}

# Where a template's campaign expects its hardware: a placeholder on the local network
# and the usual first USB serial adapters, one per gauge.
TEMPLATE_CONTROLLER = ControllerSpec(profile="cia402", port="192.168.0.10:502")


def machine_template() -> str:
    # nameless: a machine file is named after itself unless it says otherwise
    return machine_text(replace(PAPER_PROTOTYPE, name=""), MACHINE_HEADER,
                        footer=MACHINE_FOOTER)


def campaign_template(path: Path, machine_path: Path) -> str:
    """The campaign template as it reads when written to ``path``."""
    gauges = [GaugeSpec(key, "mitutoyo-01a", f"/dev/ttyUSB{n}")
              for n, key in enumerate(GAUGE_KEYS)]
    campaign = Campaign(path, PAPER_PROTOTYPE, machine_path,
                        path.parent / "sessions" / f"{path.stem}.jsonl", ProtocolConfig(),
                        controller=TEMPLATE_CONTROLLER, gauges=gauges)
    return campaign_text(campaign, comment=CAMPAIGN_HEADER,
                         notes={"controller": _controller_note(), **CAMPAIGN_NOTES})


def _controller_note() -> str:
    """The profiles shipped with the drivers, as `--profile` offers them (not a list kept
    by hand: a new register map is named as soon as its file is there)."""
    from ogacq_drivers.axes.profile import available_profiles

    return (f"profile: {', '.join(available_profiles())} or a profile file;\n"
            "port: host:port (Modbus TCP) or a serial device (Modbus RTU)")
