"""Worked examples of the public controller API (drive_common.controller_api)."""
