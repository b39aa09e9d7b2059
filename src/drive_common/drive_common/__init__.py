"""Shared pieces of the DTC drive stack (parameter schema, lockstep QoS, test harness)."""
