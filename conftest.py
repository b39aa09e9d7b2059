"""Test-suite wide set-up: the launch-free harness fixtures and DDS isolation."""
import os

os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
os.environ.pop('ROS_LOCALHOST_ONLY', None)

pytest_plugins = ['drive_testing.pytest_fixtures']

# Property-based tests: a fixed example sequence in CI (a failure there is reproducible), new
# examples on every local run (HYPOTHESIS_PROFILE=deep for a longer hunt).
from hypothesis import settings as _hypothesis_settings  # noqa: E402

_hypothesis_settings.register_profile('default', max_examples=200)
_hypothesis_settings.register_profile('ci', max_examples=200, derandomize=True, database=None)
_hypothesis_settings.register_profile('deep', max_examples=3000)
_hypothesis_settings.load_profile(os.environ.get('HYPOTHESIS_PROFILE', 'ci' if os.environ.get('CI') else 'default'))
