"""Uncertainty of a calibration: the GUM budget of each identified parameter and
leg-parallelism deviation, its Monte-Carlo check (GUM Supplement 1), and the
acceptance of the deviations against their tolerances (docs/calibration-record.md
sections 3-4)."""
