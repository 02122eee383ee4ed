"""Compensation: what a controller (or ogacq itself) must correct, from error maps
(ARCHITECTURE.md, "error maps and compensation", names each module's part).

Computed from the model alone: nothing here opens a device or a session.
"""
