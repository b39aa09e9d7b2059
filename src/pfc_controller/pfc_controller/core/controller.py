"""Alias kept for docs/architecture.md (``pfc_controller.core.controller.PfcCore``)."""
from pfc_controller.core.average_current_control import PfcCore, PfcStatusSample

__all__ = ['PfcCore', 'PfcStatusSample']
