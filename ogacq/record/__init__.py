"""The calibration record: what a campaign becomes once a metrology engineer signs it
(docs/calibration-record.md)."""
