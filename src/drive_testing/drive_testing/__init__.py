"""Test and benchmark tooling of the DTC drive stack (not needed at run time)."""
