"""Errors in files a user gave us: the input branch of the project's exceptions
(``ogacq.errors``), named here for the io package's readers."""

from __future__ import annotations

from ogacq.errors import InputError, StorageError

__all__ = ["InputError", "StorageError"]
