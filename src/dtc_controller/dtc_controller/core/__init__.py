"""ROS-agnostic DTC controller core (pure Python + numpy; no rclpy, no *_msgs, no plant code).

One module per concept (frames: :mod:`drive_common.signals`): :mod:`backemf_table`,
:mod:`hysteresis`, :mod:`vectors`, :mod:`switching_tables`,
:mod:`stator_flux_estimators`, :mod:`voltage_drop_compensation`, :mod:`speed_loop`,
:mod:`position`, one module per mode under :mod:`modes`, and
:mod:`controller` (``DtcCore``, dispatching by the ``mode`` parameter).
"""
