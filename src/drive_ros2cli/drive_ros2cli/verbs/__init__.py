"""One module per ``ros2`` command; each has ``DESCRIPTION`` and ``add_verbs(subparsers)``."""
