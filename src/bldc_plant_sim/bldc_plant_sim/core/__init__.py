"""ROS-agnostic plant physics (no rclpy, no message packages).

One module per concept: :mod:`backemf` (shapes and lookup tables),
:mod:`motor`, :mod:`inverter`, :mod:`dc_link`, :mod:`load`, :mod:`sensors`,
:mod:`protection`, :mod:`plant` (PlantCore: assembly, integration, energy
accounting), :mod:`cosim` (headless lockstep loop) and :mod:`lockstep` (the
schedule shared with the plant node).
"""
