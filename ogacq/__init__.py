"""ogacq: acquisition and calibration for Orthoglide-type parallel machines."""

__version__ = "0.1.0"
