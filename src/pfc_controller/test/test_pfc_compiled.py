"""The compiled PFC kernels give bit-identical trajectories to the same code interpreted."""
import math

import numpy as np

from drive_common.compiled import jit_disabled, libm_pow
from drive_testing.compiled_parity import differing, interpreted_and_compiled, requires_jit
from pfc_controller.core.average_current_control import pfc_step
from pfc_controller.core.feedforward import feedforward_c

pytestmark = requires_jit()

PFC_SCENARIOS = ['pfc_no_load_fig_3_5', 'pfc_load_fig_3_6', 'pfc_without_pfc_fig_3_4',
                 'pfc_protection_trips', 'pfc_load_and_line_steps', 'pfc_seed_structure_only']


def test_kernels_are_compiled():
    assert not jit_disabled()
    assert hasattr(pfc_step, 'py_func') and hasattr(feedforward_c, 'py_func')   # numba dispatchers


def test_libm_pow_squares_like_cpython():
    """x ** 2 in CPython is libm pow, not x * x; the compiled eq. (3.5) must square the same way."""
    km = np.random.default_rng(3).uniform(1.1, 10.0, 20000).tolist()
    v = 2.0 / math.pi                                      # the clamp's upper end: C = 1 / km^2
    assert sum(4.0 / (math.pi * v * k) ** 2 != 4.0 / ((math.pi * v * k) * (math.pi * v * k))
               for k in km) > 0                              # the difference this guards against
    assert [feedforward_c(v, k) for k in km] == [4.0 / (math.pi * v * k) ** 2 for k in km]
    if jit_disabled():
        assert libm_pow is math.pow


def test_compiled_equals_interpreted_bit_for_bit(tmp_path):
    interpreted, compiled = interpreted_and_compiled('drive_testing.compiled_parity:scenario_arrays',
                                                     [PFC_SCENARIOS, 0.02], tmp_path)
    assert 'pfc_no_load_fig_3_5:pfc/status.duty' in compiled
    assert differing(interpreted, compiled) == []
