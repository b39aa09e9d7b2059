"""The embedded ``ros2`` command: upstream ros2cli's verbs for the PyPI-wheel set-up."""
