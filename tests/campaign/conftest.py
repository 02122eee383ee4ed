from pathlib import Path

import pytest

MACHINE = """leg_length_mm = 310.25
rho_min_mm = -100.0
rho_max_mm = 60.0
gauge_resolution_mm = 0.001
"""

# Pieces of hand-written campaign files (a controller nobody listens on).
HEAD = 'machine = "machine.toml"\nsession = "s.jsonl"\n'
CONTROLLER = '[controller]\nprofile = "cia402"\nport = "127.0.0.1:1"\n'


def gauge(key: str, port: str, channel: int | None = None) -> str:
    """One [[gauges]] entry."""
    text = f'[[gauges]]\ngauge = "{key}"\nprotocol = "mitutoyo-01a"\nport = "{port}"\n'
    return text + (f"channel = {channel}\n" if channel is not None else "")


def write_campaign(folder: Path, *, seed: int = 3, speed: float = 50, noise: float | None = None,
                   profile: str = "cia402", extra: str = "", line_at_speed: bool = False,
                   ) -> Path:
    """A simulated campaign file (and its machine file) in ``folder``.

    ``line_at_speed``: the gauges' serial lines run ``speed`` times faster than their baud
    rates, as ``calibrate --simulator`` runs them: for a test of what a campaign records
    and concludes, not of the line's timing nor of a kill raced against the readings
    (a whole campaign's wait on its lines, about 2.6 s at 9600 baud, then takes 0.05 s)."""
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "machine.toml").write_text(MACHINE)
    sim = f"seed = {seed}\nspeed = {speed}\nprofile = \"{profile}\"\n"
    if line_at_speed:
        sim += "line_at_speed = true\n"
    if noise is not None:
        sim += f"noise_mm = {noise}\n"
    path = folder / "campaign.toml"
    path.write_text('machine = "machine.toml"\nsession = "session.jsonl"\n\n[simulator]\n'
                    + sim + "\n[protocol]\nsettle_s = 0.5\n" + extra)
    return path


@pytest.fixture
def campaign_dir(tmp_path):
    return tmp_path / "campaign"
