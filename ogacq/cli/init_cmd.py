"""``ogacq init machine|campaign [FILE]``: a commented template to start a file from."""

from __future__ import annotations

from enum import StrEnum
from pathlib import Path
from typing import Annotated

import typer

from ogacq.campaign.templates import campaign_template, machine_template
from ogacq.cli.outputs import ForceOption, check_output_file
from ogacq.cli.plain import print_wrapped
from ogacq.io.atomic import write_atomically


class FileKind(StrEnum):
    machine = "machine"
    campaign = "campaign"


def init(
    kind: Annotated[FileKind, typer.Argument(help="Which file to start.")],
    file: Annotated[Path | None, typer.Argument(
        help="File to write (default: machine.toml or campaign.toml here).")] = None,
    machine: Annotated[Path | None, typer.Option(
        "--machine", "-m", help="The machine file a campaign names (default: machine.toml "
                                "beside it).")] = None,
    force: ForceOption = False,
) -> None:
    """Write a commented template of a machine or a campaign file to edit."""
    path = file or Path(f"{kind.value}.toml")
    check_output_file(path, "FILE", force=force)
    if kind is FileKind.machine:
        write_atomically(path, machine_template().encode("utf-8"))
        print_wrapped(f"machine file written to {path}: edit its values")
        return
    machine_path = machine or path.parent / "machine.toml"
    write_atomically(path, campaign_template(path, machine_path).encode("utf-8"))
    print_wrapped(f"campaign file written to {path}: set its ports, then `ogacq run {path}`")
    if not machine_path.exists():
        print_wrapped(f"it names the machine file {machine_path}, not there yet: "
                      f"`ogacq init machine {machine_path}`")
