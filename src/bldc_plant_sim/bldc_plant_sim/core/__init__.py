"""ROS-agnostic plant physics (no rclpy, no message packages): one module per part, :mod:`plant`
(PlantCore) assembling them, :mod:`cosim` (headless lockstep loop) and :mod:`lockstep` (the
schedule shared with the plant node)."""
