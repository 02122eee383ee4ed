"""A validation judged with the model that was written (issue 38.4): after `offsets
write --from-diagnosis` on a machine out of square, the validation campaign's joint
offsets alone are biased by the squareness that stays ("NOT within the gauge noise",
offsets of some hundredths: a write-back that looks failed); its end says the same
campaign judged with the diagnosis's effects carried over, and that is within."""

from __future__ import annotations

from ogacq.cli.campaign_end import campaign_end
from ogacq.session.identification import identify_session
from ogacq.session.store import load_session
from tests.writeback.conftest import ogacq, sim_campaign, simulator, synthetic_session

OFFSETS = {"x": 0.8, "y": -0.6, "z": 1.2}
SQUARENESS = {"squareness.xy": 0.5}


def test_the_validation_after_a_diagnosis_write_carries_its_effects(tmp_path):
    with simulator(tmp_path, "cia402", seed=7) as info:
        campaign = sim_campaign(tmp_path, info, name="campaign")
        calibration = synthetic_session(tmp_path / "askew.jsonl", campaign,
                                        offsets_mm=OFFSETS, effects=SQUARENESS)
        written = ogacq("offsets", "write", calibration, "--from-diagnosis", "--yes",
                        "--history", "none")
        assert written.returncode == 0, written.stderr
    # the machine as left: the offsets corrected, the squareness where it was
    validation = synthetic_session(tmp_path / "askew-2.jsonl", campaign,
                                   offsets_mm=dict.fromkeys(OFFSETS, 0.0),
                                   effects=SQUARENESS, seed=1)
    fit = identify_session(load_session(validation))
    end = campaign_end(validation, fit, simulated=False)
    assert end.verdict.state == "inconsistent"  # the joint offsets alone: biased
    lines = end.lines()
    carried = lines[1]
    assert carried.startswith("judged with the effects the diagnosis of askew.jsonl found "
                              "carried over (squareness.xy"), lines
    assert carried.endswith(")") and "within the gauge noise" in carried
    assert "NOT within" not in carried
    left = {part.split()[0]: float(part.split()[1])
            for part in carried.split("joint offsets left ")[1].split(" mm")[0].split(", ")}
    assert all(abs(v) < 0.005 for v in left.values()), left
    assert lines[-1].startswith(f"next: ogacq report {calibration} --after {validation}")


def test_a_campaign_that_validates_nothing_carries_nothing(tmp_path):
    campaign = tmp_path / "campaign.toml"
    plain = synthetic_session(tmp_path / "plain.jsonl", campaign, offsets_mm=OFFSETS,
                              effects=SQUARENESS)
    end = campaign_end(plain, identify_session(load_session(plain)), simulated=False)
    assert end.carried is None and not end.lines()[1].startswith("judged with")
