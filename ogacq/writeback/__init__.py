"""Writing identified joint offsets and error maps back to the machine, and undoing it
(ARCHITECTURE.md, "writing offsets to the controller", names each module's part).

Modules are imported directly (``from ogacq.writeback.policy import ...``): the
station loads ``table`` while campaigns import the station, so this package
imports nothing itself.
"""
