"""Calibration and identification: the report's appendix A.1 procedures (placeholder, filled below)."""
