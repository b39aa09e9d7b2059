"""Analysis of drive runs without ROS: metrics (one registry), figures, the ``analyze`` command.

Public face: :func:`drive_analysis.registry.lookup` / :func:`~drive_analysis.registry.evaluate`
(metrics by name on the flat arrays dict of :mod:`drive_analysis.arrays`),
:mod:`drive_analysis.figures`, :func:`drive_analysis.bag_columns.load_columns`.
"""
