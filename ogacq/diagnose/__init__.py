"""Mismatch diagnosis: is the identified model within the gauge noise, where does the
misfit sit, which left-out physics explains it, and what would tell the candidates apart.

Entry point: :func:`ogacq.diagnose.diagnosis.diagnose`.
"""
