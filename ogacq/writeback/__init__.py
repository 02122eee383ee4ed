"""Writing identified joint offsets back to the controller, and undoing it.

- ``evidence``: the identified offsets of a session, their std and the fit verdict;
- ``policy``: the plan (old -> new per axis) and every reason to refuse it;
- ``execute``: write, read back, save, re-home, with audit records;
- ``audit``: the records in the session, and the operations they describe;
- ``table``: the software offset table of profiles without an offset register.

Modules are imported directly (``from ogacq.writeback.policy import ...``): the
station loads ``table`` while campaigns import the station, so this package
imports nothing itself.
"""
