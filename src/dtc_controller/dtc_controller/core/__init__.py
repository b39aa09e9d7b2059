"""ROS-agnostic DTC controller core (pure Python + numpy; no rclpy, no *_msgs, no plant code).

One module per concept, the modes under :mod:`modes`; :mod:`controller` (``DtcCore``)
dispatches by the ``mode`` parameter.
"""
