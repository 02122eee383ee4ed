"""Compensation: what a controller (or ogacq itself) must correct, from error maps.

- ``effects``: the diagnosis's library effects a controller can compensate
  (encoder scale, backlash) as error maps (``ogacq.model.axis_map.AxisMap``);
- ``combine``: one map per axis from the diagnosis's maps and those effects, less
  what the kinematic model already corrects (never correct twice);
- ``iso230``: the ISO 230-2 figures of an axis (A, B, R, E, M) from a map;
- ``linuxcnc``, ``fanuc``, ``siemens``, ``plain_csv``: the tables in each
  controller's own format, each written from its documentation, with what the
  controller then applies (for the predicted residual);
- ``export``: every format written into a folder, the figures beside each table;
- ``applied``: ogacq's own correction of the targets it commands (Modbus drives
  without a table).

Computed from the model alone: nothing here opens a device or a session.
"""
