"""A trivial controller core: a fixed gate pattern (no rclpy).

Used by the ``fixed_responder`` node, by plant tests (the ROS graph and the
headless loop must give the same trajectory) and by benchmarks.
"""
from __future__ import annotations

from dataclasses import dataclass

from drive_common.samples import DriveSample, GateSample


@dataclass
class FixedGateCore:
    """Answers every drive sample with the same switch states."""

    switch_on: tuple = (True, False, False, True, False, False)  # a+ b-: vector "ab"
    topology: int = 6

    def update(self, sample: DriveSample):
        return GateSample(step=sample.step, topology=self.topology, switch_on=self.switch_on), None

    @property
    def constant_gates(self) -> tuple:
        """The gates of every answer (a fused headless loop may skip the calls: drive_bringup.fused)."""
        return self.switch_on

    def reconfigure(self, params: dict) -> None:
        self.switch_on = tuple(bool(s) for s in params['switch_on'])
        self.topology = int(params['topology'])
