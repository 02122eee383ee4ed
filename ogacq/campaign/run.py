"""Running a campaign end to end: station, session, runner, identification.

``ogacq run``, ``ogacq resume``, ``ogacq demo`` and the wizard all come here;
they differ only in how they show progress and where the campaign comes from.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ogacq.campaign.campaign_file import Campaign, read_campaign
from ogacq.campaign.station import DeviceStation, open_station
from ogacq.campaign.traceability import check_instruments, header_entries, read_environment
from ogacq.compensation.applied import TargetCorrection
from ogacq.identify.fit import FitResult
from ogacq.io.errors import InputError
from ogacq.protocol.deadline import DeadlineStation, default_deadline_s
from ogacq.protocol.plan import ProtocolConfig, SetGauges, reading_steps
from ogacq.protocol.runner import CampaignRunner, GaugeSetter, Observer
from ogacq.protocol.station import Station
from ogacq.session.convert import machine_dict
from ogacq.session.identification import identify_session
from ogacq.session.offsets_in_force import stations
from ogacq.session.records import (
    EnvironmentRecord,
    OperatorRecord,
    OverrideRecord,
    ResultRecord,
    StationRecord,
)
from ogacq.session.store import LoadedSession, SessionWriter, check_writable, load_session
from ogacq.writeback.maps_table import MapsTable, maps_checksum, read_maps_table

if TYPE_CHECKING:
    from ogacq.sim.stack import SimulatorStack

# Adapts the station for one run (the wizard's pauses and gauges read by eye): gets the
# station the campaign runs on, the device station it opened and the session writer.
StationAdapter = Callable[[Station, DeviceStation, SessionWriter], Station]
# The temperatures at the end, asked of someone (the wizard asks the operator).
EnvironmentAsker = Callable[[DeviceStation], EnvironmentRecord | None]


@dataclass
class CampaignOutcome:
    session_path: Path
    fit: FitResult
    hidden: dict[str, float] | None  # the simulator's truth, when simulated
    simulated: bool = False  # a rehearsal: the built-in simulator, or `ogacq sim`'s drives
    # the controller stopped with the command (the built-in simulator): nothing to write to
    controller_gone: bool = False


def run_campaign(campaign: Campaign, *, observer: Observer | None = None,
                 set_gauges: GaugeSetter | None = None,
                 resume: LoadedSession | None = None,
                 simulator: SimulatorStack | None = None,
                 wrap_station: StationAdapter | None = None,
                 header_extra: dict[str, Any] | None = None,
                 environment_at_end: EnvironmentAsker | None = None,
                 checked: Callable[[], None] | None = None) -> CampaignOutcome:
    """Run (or resume) a campaign; raises CampaignStopped when it cannot finish.

    ``simulator``: a running simulator to use instead of starting one;
    ``wrap_station``: adapts the opened station for this run (the wizard's pause
    checkpoints and gauges read by eye); ``header_extra``: more session header;
    ``environment_at_end``: asks the temperatures at the end (default: the sensor or
    the simulator the campaign names, if any); ``checked``: called once the campaign
    passed its gates (session writable, gauges in date) and its station opened, before
    anything moves.
    """
    # before the station opens: a session that cannot be written is found before homing
    check_writable(resume.path if resume is not None else campaign.session,
                   resuming=resume is not None)
    # ... and a gauge past its due date before anything moves (Refused, unless overridden)
    overrides = check_instruments(campaign, overridden=[
        r.subject for r in resume.of_type(OverrideRecord)] if resume is not None else ())
    # ... and maps the session was not recorded with (its readings would mix two)
    maps = maps_in_force(campaign)
    if resume is not None:
        check_same_maps(resume, maps)
    with open_station(campaign, simulator) as station:
        if checked is not None:
            checked()
        started = resume is None or not resume.of_type(EnvironmentRecord)
        environment = read_environment(campaign, station, "start") if started else None
        station.prepare()
        if maps is not None:  # the identity of the maps every target is corrected with
            station.description["controller"]["maps"] = maps.identity()
        station.description["deadline_s"] = campaign.deadline_s or default_deadline_s(
            campaign.protocol, campaign.machine)
        recorded_before = resume.recorded() if resume is not None else set()
        if station.simulator is not None and station.simulator.moves_indicators:
            set_gauges = _simulated_operator(station.simulator, campaign, recorded_before,
                                             set_gauges)
        writer, recorded = _session_writer(campaign, station, resume, header_extra)
        with writer:
            for record in (*overrides, environment):
                if record is not None:
                    writer.write(record)
            station.record_event = writer.write
            # inside the wizard's wrapper: its pauses are the operator's time, not the work's
            works = DeadlineStation(station, station.description["deadline_s"])
            runs_on = wrap_station(works, station, writer) if wrap_station else works
            # a resumed campaign was homed anew (prepare): the readings on file hold only
            # if the machine reads the same at the posture of the last of them
            previous = resume.readings if resume is not None else ()
            runner = CampaignRunner(runs_on, writer, campaign.protocol, campaign.machine,
                                    recorded=recorded, observer=observer,
                                    set_gauges=set_gauges, previous=previous,
                                    check_first=bool(previous),
                                    correction=target_correction(campaign, maps))
            runner.run()
            result = _close_campaign(campaign, station, writer, environment_at_end)
        hidden = station.simulator.machine.truth.hidden() if station.simulator else None
    return CampaignOutcome(writer.path, result, hidden, station.description["simulated"],
                           controller_gone=station.simulator is not None)


def _session_writer(campaign: Campaign, station: DeviceStation, resume: LoadedSession | None,
                    header_extra: dict[str, Any] | None,
                    ) -> tuple[SessionWriter, set[tuple[str, str]]]:
    """The session to record into, and the (step, gauge) readings it holds: a new one
    with its header, or the resumed one told of the station it reopens with."""
    if resume is not None:
        writer = SessionWriter.reopen(resume)
        writer.write(StationRecord(description=station.description))
        return writer, resume.recorded()
    header = {"machine": machine_dict(campaign.machine),
              "machine_file": str(campaign.machine_path),
              "campaign_file": str(campaign.path.resolve()),
              # said once and loudly: a rehearsal is never the machine's record
              "simulated": station.description["simulated"],
              "station": station.description, "plan": campaign.protocol.to_dict(),
              **header_entries(campaign, station.description["gauges"]),
              **(header_extra or {})}
    if station.simulator is not None and campaign.simulator is not None:
        header["simulator"] = campaign.simulator.header()
    return SessionWriter.create(campaign.session, header), set()


def target_correction(campaign: Campaign, maps: MapsTable | None) -> TargetCorrection | None:
    """The maps in force applied to every target (None: no maps file, or an empty one)."""
    if maps is None or not maps.maps:
        return None
    return TargetCorrection(maps.maps, (campaign.machine.rho_min_mm,
                                        campaign.machine.rho_max_mm))


def _close_campaign(campaign: Campaign, station: DeviceStation, writer: SessionWriter,
                    environment_at_end: EnvironmentAsker | None) -> FitResult:
    """After the last reading: the temperatures at the end, then the campaign's own
    identification, recorded."""
    at_end = environment_at_end or (lambda st: read_environment(campaign, st, "end"))
    ended = at_end(station)
    if ended is not None:
        writer.write(ended)
    result = identify_session(load_session(writer.path))
    writer.write(ResultRecord(params="offsets", refit=result.to_json("offsets"),
                              noise_mm=result.noise.sigma_mm,
                              noise_source=result.noise.source))
    return result


def maps_in_force(campaign: Campaign) -> MapsTable | None:
    """The maps file the campaign's controller names, read (None: it names none)."""
    spec = campaign.controller
    if spec is None or spec.maps_file is None:
        return None
    return read_maps_table(spec.maps_file,  # the maps of this machine only
                           owner=(campaign.machine.name, campaign.machine.serial))


def recorded_maps(session: LoadedSession) -> dict[str, Any] | None:
    """The maps identity the campaign last ran with (None: none were applied)."""
    for station in reversed(stations(session)):
        controller = station.get("controller") or {}
        if "maps" in controller or "maps_file" in controller:
            return controller.get("maps")
    return None


def check_same_maps(session: LoadedSession, maps: MapsTable | None) -> None:
    """Refuse to resume with other maps than the session's readings were taken with
    (``maps`` None: the campaign names no maps file, so none are applied)."""
    before = recorded_maps(session)
    then = str(before.get("checksum")) if before else maps_checksum({})  # none applied then
    now = maps.checksum if maps is not None else maps_checksum({})
    if then != now:
        where = maps.path if maps is not None else session.path
        raise InputError(where, f"the maps applied changed since {session.path} was started "
                         f"(then {then[:12]}, now {now[:12]}): its readings would mix two "
                         "compensations; resume with the maps it started with (a calibration's "
                         "campaign: `ogacq calibrate --resume`), or start a new campaign")


def _simulated_operator(simulator: SimulatorStack, campaign: Campaign,
                        recorded: set[tuple[str, str]], then: GaugeSetter | None,
                        ) -> GaugeSetter:
    """With the simulator's two indicators moved leg to leg, its operator moves them
    when the plan says so (before whoever else is told); a resumed campaign finds
    them on the leg it stopped at."""
    pending = next((step for step in reading_steps(campaign.protocol, campaign.machine)
                    if any((step.step, g) not in recorded for g in step.gauges)), None)
    if pending is not None:
        simulator.set_gauges(pending.leg)

    def set_gauges(step: SetGauges) -> None:
        simulator.set_gauges(step.leg)
        if then is not None:
            then(step)

    return set_gauges


def gauges_read_by_eye(session: LoadedSession) -> set[str]:
    """Gauges whose values the operator types (chosen at the start, or switched to
    mid-way when a gauge failed): only the wizard can ask for them."""
    wizard = session.header.wizard
    chosen = wizard.get("by_eye", []) if wizard is not None else []
    switched = {r.details["gauge"] for r in session.of_type(OperatorRecord)
                if r.action == "read_by_eye"}
    return set(chosen) | switched


def resumable_campaign(session: LoadedSession) -> Campaign:
    """The campaign an interrupted session continues with (its file, its plan)."""
    if session.finished:
        raise InputError(session.path, "this campaign is complete; nothing to resume "
                         "(`ogacq refit` re-identifies it)")
    campaign_file = session.header.campaign_file
    if not campaign_file:
        raise InputError(session.path, "this session was not recorded by a campaign "
                         "(no campaign file): it cannot be resumed", 1)
    by_eye = gauges_read_by_eye(session)
    if by_eye:
        raise InputError(session.path, f"gauges {', '.join(sorted(by_eye))} are read by eye: "
                         f"continue with `ogacq wizard --resume {session.path}`")
    campaign = read_campaign(campaign_file)
    if not _same_plan(campaign.protocol, session.header.plan):
        raise InputError(campaign.path, f"the protocol differs from the one {session.path} "
                         "was started with; resume needs the same plan")
    campaign.session = session.path
    return campaign


def _same_plan(protocol: ProtocolConfig, recorded: Any) -> bool:
    """The campaign file's protocol is the one the session was started with; a plan
    recorded before a key existed reads with that key's default."""
    try:
        return ProtocolConfig.from_dict(recorded).to_dict() == protocol.to_dict()
    except (TypeError, ValueError):
        return False
