"""Test-suite wide set-up: the launch-free harness fixtures and DDS isolation."""
import os

os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
os.environ.pop('ROS_LOCALHOST_ONLY', None)

pytest_plugins = ['drive_testing.pytest_fixtures']
