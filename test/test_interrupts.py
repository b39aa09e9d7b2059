"""SIGINT or SIGTERM stops every node of a running graph cleanly.

A recorded graph (plant with ``run_until``, dtc_controller, recorder) is
interrupted 20 times at seeded random moments of its run (mid-run, or held
after a short run), with SIGINT or SIGTERM to every process at once (as Ctrl-C in a terminal, or a process
manager stopping the graph): each process exits with code 0 (no crash, no
core dump), logs nothing at ERROR, and the recorder leaves a bag a strict reader opens.
"""
import os
import random
import signal
import subprocess
import time
from pathlib import Path

import pytest

from drive_common import topics
from drive_testing.harness import wait_until
from drive_logger.bag_reader import BagReader
from dtc_msgs.msg import PlantState

pytestmark = pytest.mark.ros

INTERRUPTS = 20
SEED = 13
BACKEMF_TABLE = (Path(__file__).resolve().parents[1] / 'src' / 'bldc_plant_sim' / 'motors'
                 / 'ozturk_bldc_backemf.csv')


def test_interrupted_graph_exits_cleanly_every_time(start_node, ros_session, tmp_path):
    rng = random.Random(SEED)
    probe = ros_session.node('state_probe')
    subscription = None
    for attempt in range(INTERRUPTS):
        # A new subscription per attempt: a state of the previous (stopped) plant still queued
        # in the old one must not pass for this plant's run being under way.
        if subscription is not None:
            probe.destroy_subscription(subscription)
        states: list = []
        subscription = probe.create_subscription(PlantState, topics.PLANT_STATE, states.append,
                                                 topics.STREAM_QOS)
        bag = tmp_path / f'bag_{attempt}'
        logs = {'log_dir': tmp_path / f'nodes_{attempt}'}
        recorder = start_node('drive_logger', 'recorder', parameters={'output': str(bag)}, **logs)
        # The hand-started recipe: the plant starts once the recorder is up (a recorder
        # still importing is not in the graph the plant waits on before its run).
        wait_until(lambda: 'recorder ready' in recorder.output(), 120.0,
                   what=f'recorder {attempt} ready')
        controller = start_node('dtc_controller', 'dtc_controller',
                                parameters={'backemf_table_path': str(BACKEMF_TABLE),
                                            'torque_reference': 0.5}, **logs)
        plant = start_node('bldc_plant_sim', 'plant',
                           parameters={'motor.file': 'ozturk_bldc', 'dc_link.voltage': 56.57,
                                       'run_until': rng.choice((0.05, 0.5))}, **logs)
        graph = (plant, controller, recorder)
        wait_until(lambda: (states and states[-1].step > 0) or 'run_until finished' in
                   plant.output(), 120.0, what=f'run {attempt} under way')
        delay = rng.uniform(0.0, 3.0)
        sig = rng.choice((signal.SIGINT, signal.SIGTERM))
        time.sleep(delay)                         # the random moment (not a wait on a condition)
        for process in graph:
            os.killpg(process.pid, sig)           # its process group, as a terminal does
        for process in graph:
            try:
                code = process.process.wait(timeout=60)
            except subprocess.TimeoutExpired:
                process.stop()                    # its thread stacks go to its output first
                pytest.fail(f'{attempt} {sig.name}: {process.executable} did not exit within 60 s:\n'
                            f'{process.output()[-8000:]}')
            assert code == 0, (attempt, sig.name, process.executable, process.output()[-3000:])
            # A clean interrupt is not an error: nothing logged at ERROR (the run's end at INFO).
            errors = [line for line in process.output().splitlines() if '[ERROR]' in line]
            assert not errors, (attempt, sig.name, process.executable, errors)
        messages = sum(1 for _ in BagReader(bag).messages())
        assert messages > 0, (attempt, 'empty bag')
