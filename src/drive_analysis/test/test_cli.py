"""analyze: a synthetic run bag -> JSON summary with the right numbers, and the PNGs."""
import json
import math

import numpy as np
import pytest
from rclpy.serialization import serialize_message

from drive_common.conversions import time_msg
from drive_analysis import cli as analysis_cli
from drive_logger import qos_yaml
from drive_logger.bag_writer import BagWriter
from drive_logger.message_definitions import type_definition
from dtc_msgs.msg import DtcStatus, PlantState

F1 = 100.0     # Hz, electrical frequency of the synthetic currents
TS = 2e-5      # s


def _write_run(path, steps=4000, namespaces=('',)):
    """A run bag; namespaces: one drive recorded under each ('' = none), the same samples."""
    writer = BagWriter(path)
    topics = [(writer.add_topic(ns + '/plant/state', type_definition('dtc_msgs/msg/PlantState'),
                                [qos_yaml.profile()]),
               writer.add_topic(ns + '/dtc/status', type_definition('dtc_msgs/msg/DtcStatus'),
                                [qos_yaml.profile()])) for ns in namespaces]
    for k in range(steps):
        t = k * TS
        w = 2 * math.pi * F1 * t
        state = PlantState(step=k, electromagnetic_torque=0.3 + 0.01 * math.sin(125 * w),
                           rotor_angle=w % (2 * math.pi), mechanical_speed=2 * math.pi * F1 / 4,
                           grid_voltage=100 * math.sin(2 * math.pi * 60 * t),
                           grid_current=2 * math.sin(2 * math.pi * 60 * t - 0.3))
        state.phase_current = [2 * math.sin(w - n * 2 * math.pi / 3) + 0.1 * math.sin(5 * (w - n * 2 * math.pi / 3))
                               for n in range(3)]
        state.header.stamp = time_msg(t)
        status = DtcStatus(step=k, torque_reference=0.3, torque_estimate=0.3 + 0.01 * math.sin(125 * w) + 0.002,
                           flux_alpha=0.1 * math.cos(w), flux_beta=0.1 * math.sin(w), flux_magnitude=0.1,
                           rotor_angle_estimate=(w + 0.01) % (2 * math.pi), speed_reference=float('nan'))
        status.header.stamp = time_msg(t)
        now = 1_000_000_000 + k * 1000
        for state_t, status_t in topics:
            writer.write(state_t, serialize_message(state), now, now)
            writer.write(status_t, serialize_message(status), now, now)
    writer.close()


def test_analyze_writes_summary_and_figures(tmp_path):
    _write_run(tmp_path / 'run')
    out = tmp_path / 'out'
    assert analysis_cli.main([str(tmp_path / 'run'), '--out', str(out), '--rated-torque', '0.3']) == 0
    summary = json.loads((out / 'summary.json').read_text())
    assert summary['current_fundamental_frequency'] == pytest.approx(F1, rel=0.02)
    assert summary['current_thd_total_percent'] == pytest.approx(5.0, rel=1e-2)
    assert summary['current_balance']['imbalance_percent'] == pytest.approx(0.0, abs=0.1)
    assert summary['torque_ripple_factor_window_percent'] == pytest.approx(0.02 / 0.3 * 100, rel=2e-2)
    assert summary['power_factor'] == pytest.approx(math.cos(0.3) * 1.0, abs=5e-3)
    assert summary['torque_estimation_error']['mean'] == pytest.approx(0.002, abs=1e-9)
    assert summary['angle_estimation_error']['max_abs'] == pytest.approx(0.01, abs=1e-9)
    for name in ('flux_locus', 'torque', 'phase_currents', 'speed', 'rotor_angle', 'grid'):
        png = out / f'{name}.png'
        assert png.read_bytes()[:8] == b'\x89PNG\r\n\x1a\n', name


def test_analyze_reports_a_damaged_bag(tmp_path, capsys):
    _write_run(tmp_path / 'run', steps=200)
    (tmp_path / 'run' / 'metadata.yaml').unlink()
    assert analysis_cli.main([str(tmp_path / 'run')]) == 2
    assert 'metadata.yaml' in capsys.readouterr().err
    np.testing.assert_equal(analysis_cli.main([str(tmp_path / 'run'), '--salvage', '--out', str(tmp_path / 'o')]), 0)


def _without_figures(out) -> dict:
    """The summary analyze wrote into out, figure paths (which name out) left out."""
    summary = json.loads((out / 'summary.json').read_text())
    assert sorted(summary.pop('figures')), 'no figure drawn'
    return summary


def test_analyze_reads_a_namespaced_drive_as_the_same_drive_without(tmp_path, capsys):
    _write_run(tmp_path / 'plain', steps=1000)
    _write_run(tmp_path / 'one', steps=1000, namespaces=('/drive1',))
    assert analysis_cli.main([str(tmp_path / 'plain'), '--out', str(tmp_path / 'a')]) == 0
    plain = _without_figures(tmp_path / 'a')
    assert analysis_cli.main([str(tmp_path / 'one'), '--out', str(tmp_path / 'b')]) == 0
    assert _without_figures(tmp_path / 'b') == plain
    # Two drives: --namespace chooses; without it, a one-line error lists them.
    _write_run(tmp_path / 'two', steps=1000, namespaces=('/drive1', '/drive2'))
    capsys.readouterr()
    assert analysis_cli.main([str(tmp_path / 'two')]) == 2
    error = capsys.readouterr().err.strip()
    assert len(error.splitlines()) == 1 and '/drive1, /drive2' in error and '--namespace' in error
    assert analysis_cli.main([str(tmp_path / 'two'), '--namespace', 'drive2',
                              '--out', str(tmp_path / 'c')]) == 0
    assert _without_figures(tmp_path / 'c') == plain


def test_analyze_refuses_a_bag_without_any_topic_it_knows(tmp_path, capsys):
    from std_msgs.msg import String
    writer = BagWriter(tmp_path / 'other')
    topic = writer.add_topic('/chatter', type_definition('std_msgs/msg/String'), [qos_yaml.profile()])
    writer.write(topic, serialize_message(String(data='hello')), 1, 1)
    writer.close()
    assert analysis_cli.main([str(tmp_path / 'other'), '--out', str(tmp_path / 'o')]) == 2
    error = capsys.readouterr().err.strip()
    assert len(error.splitlines()) == 1 and 'none of the topics' in error, error
