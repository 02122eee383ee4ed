"""``ogacq wizard``: a technician at a terminal, guided from connecting the
instruments to a calibration result (see ``flow.py`` for the steps)."""
