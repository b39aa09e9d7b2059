"""Fixtures for the dtc_controller core tests."""
import pytest

from dtc_test_tables import make_table


@pytest.fixture
def trap_table():
    return make_table('trapezoid')


@pytest.fixture
def sine_table():
    return make_table('sine')
