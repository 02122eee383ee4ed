"""``ogacq calibrate``: from campaign to validated machine, resumable step by step.

- ``log``: the procedure's journal (each step named, run once, replayed on a resume);
- ``setup``: the folder, the machine, the campaigns and the controller's files, on
  the built-in simulator or on a station's campaign file;
- ``maps``: the error maps a diagnosis hands over (the one place the diagnosis's
  maps are taken from) and its library effects a table can hold;
- ``separate``: whether the diagnosis is ambiguous, and the measurement that would
  separate it (a scan where a map is suspected), with its duration;
- ``compensate``: the offsets and maps to write, the tables in each format;
- ``validate``: the validation campaign judged against the one before it;
- ``procedure``: the steps in order, each resumed after a kill.
"""
