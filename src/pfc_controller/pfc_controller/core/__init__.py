"""ROS-agnostic core of the boost PFC controller (000 ch. III); no rclpy, no *_msgs."""
from pfc_controller.core.average_current_control import PfcCore, PfcStatusSample
from pfc_controller.core.feedforward import LinePeriodAverage, feedforward_c
from pfc_controller.core.pi import PiController

__all__ = ['PfcCore', 'PfcStatusSample', 'LinePeriodAverage', 'feedforward_c', 'PiController']
