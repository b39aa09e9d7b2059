"""Scenarios, the launch-free scenario runner, the headless runner and the seed reproduction table of the DTC drive stack."""
