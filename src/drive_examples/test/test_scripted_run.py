"""The scripted_run example drives a running plant: an absolute goal, then a relative one."""
import re

import pytest

from drive_common.waiting import wait_until

pytestmark = pytest.mark.ros

PLANT = {'motor.file': 'ozturk_bldc', 'dc_link.voltage': 10.0, 'motor.initial_speed': 20.0}


def test_scripted_run_runs_to_the_target_then_a_relative_step(start_node):
    start_node('drive_testing', 'fixed_responder', parameters={'switch_on': [1.0, 0.0, 0.0, 1.0, 0.0, 0.0]})
    start_node('bldc_plant_sim', 'plant', parameters=PLANT)
    script = start_node('drive_examples', 'scripted_run', extra_args=['--to', '0.002', '--then', '0.001'])
    wait_until(lambda: not script.alive(), 180.0, what='the script to end')
    out = script.output()
    assert script.process.returncode == 0, out
    steps = [int(s) for s in re.findall(r'^success=True final_step=(\d+) ', out, re.MULTILINE)]
    assert steps == [80, 120], out          # 0.002 s, then 0.001 s more, at 25 us
