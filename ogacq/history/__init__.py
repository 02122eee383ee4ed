"""Each machine's calibration history in a database.

SQLite by default (``history.sqlite`` in ogacq's data folder: a file, nothing to
install), PostgreSQL for a site whose stations share one history, through the
same schema and code, chosen by a URL:

- ``location``: which database a command uses (``--history``, ``OGACQ_HISTORY``,
  ``history.sqlite`` in ogacq's data folder): an SQLite file, or a PostgreSQL URL;
- ``schema``: the tables, declared once and rendered as each backend's DDL, and the
  schema version row, created on first use;
- ``database``: the connection (the standard library's sqlite3, or psycopg) that
  runs the store's SQL on either backend;
- ``entries``: what a record (``ogacq-record/1``) and a write-back put in the rows;
- ``store``: ``History``, the one place that reads and writes the database;
- ``drift``: changes between successive calibrations larger than their U;
- ``plot``: each parameter over time with its U.

The session stays the source of truth: the history holds the record whole with
the session's path and SHA-256, so every row can be traced back to its file.
"""
