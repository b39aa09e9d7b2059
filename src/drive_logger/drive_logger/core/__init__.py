"""ROS-agnostic parts of drive_logger's nodes (no rclpy; test/test_core_purity.py)."""
