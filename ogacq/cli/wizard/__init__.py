"""``ogacq wizard``: a technician at a terminal, guided from connecting the
instruments to a calibration result (see ``flow.py`` for the steps)."""

from ogacq.cli.wizard.flow import WizardOptions, run_wizard

__all__ = ["WizardOptions", "run_wizard"]
