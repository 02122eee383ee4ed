"""The scans a diagnosis proposes are printed with the machine file's path as it is:
a folder named ``runs [/y]`` (the fault matrix's strange name) made rich read
``[/y]`` as a closing tag and the whole ``diagnose`` end in a MarkupError, once the
diagnosis proposed a scan (tests/cli/test_records_fault_matrix.py, under load)."""

from __future__ import annotations

from types import SimpleNamespace

from ogacq.cli.render_maps import print_proposals
from ogacq.diagnose.mapswap import Proposal


def test_a_proposed_scans_command_is_printed_as_it_is(capsys):
    strange = "/tmp/runs [/y]/[bold]machine.toml"
    proposals = [Proposal("leg_length.y", "screw_map.y", 2.0, 1, -100.0, 60.0, 36.0, -5.7),
                 Proposal("the effects found", "a map", 5.0, 2, -100.0, 60.0, 12.0, 0.0)]
    for proposal in proposals:
        print_proposals(SimpleNamespace(proposals=[proposal]), strange)  # type: ignore[arg-type]
        text = "".join(capsys.readouterr().out.split())
        assert "".join(proposal.command(strange).split()) in text, text
