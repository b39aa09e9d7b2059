"""Analysis reads block bags exactly as per-sample bags: same columns, same metrics."""
import math

import pytest

from drive_analysis.arrays import flatten_columns
from drive_analysis.bag_columns import ANALYSED_TOPICS, load_columns
from drive_bringup.report import evaluate_metrics
from drive_bringup.scenario import find_scenario, load_scenario
from drive_logger.bag_reader import BagReadError
from drive_testing.block_bags import headless_samples, write_block_bag, write_per_sample_bag

DTC_SCENARIO = 'two_phase_six_switch_torque_step'     # metrics and seed checks on a torque step
PFC_SCENARIO = 'pfc_no_load_fig_3_5'                  # the PFC loop's topics too


def _bags(tmp_path_factory, name, duration):
    scenario = load_scenario(find_scenario(name))
    if duration is not None:
        scenario = scenario.shortened(duration)
    samples = headless_samples(scenario)
    root = tmp_path_factory.mktemp(name)
    return scenario, samples, {
        'per_sample': write_per_sample_bag(samples, root / 'per_sample'),
        # blocks of 40 plus the decimated live topics of the same names: the blocks must win
        'blocks': write_block_bag(samples, root / 'blocks'),
        # odd block size, no live topics, and the raw lockstep topics recorded on request
        'blocks_raw': write_block_bag(samples, root / 'blocks_raw', block_size=7, live_period=None, lockstep=True),
    }


@pytest.fixture(scope='module')
def dtc_run(tmp_path_factory):
    return _bags(tmp_path_factory, DTC_SCENARIO, None)


@pytest.fixture(scope='module')
def pfc_run(tmp_path_factory):
    return _bags(tmp_path_factory, PFC_SCENARIO, 0.004)


def assert_same_columns(expected: dict, got: dict) -> None:
    assert list(got) == list(expected)
    for topic, columns in expected.items():
        assert list(got[topic]) == list(columns), topic
        for name, values in columns.items():
            other = got[topic][name]
            assert other.dtype == values.dtype and other.shape == values.shape, (topic, name)
            if values.dtype == object:
                assert other.tolist() == values.tolist(), (topic, name)
            else:   # bit-exact, NaN payloads included
                assert other.tobytes() == values.tobytes(), (topic, name)


@pytest.mark.parametrize('which', ['blocks', 'blocks_raw'])
def test_block_bag_gives_the_per_sample_columns(dtc_run, which):
    _, samples, bags = dtc_run
    expected = load_columns(str(bags['per_sample']))
    assert set(expected) == {'/plant/state', '/dtc/status', '/drive/measurement', '/drive/gate_command'}
    assert len(expected['/dtc/status']['step']) == len(samples.dtc) > 1000
    assert len(expected['/plant/state']['step']) == len(samples.states)
    assert_same_columns(expected, load_columns(str(bags[which])))


def test_pfc_topics_from_the_pfc_block(pfc_run):
    _, samples, bags = pfc_run
    expected = load_columns(str(bags['per_sample']))
    assert set(expected) == set(ANALYSED_TOPICS)
    assert len(expected['/pfc/status']['step']) == len(samples.pfc) > 100
    for which in ('blocks', 'blocks_raw'):
        assert_same_columns(expected, load_columns(str(bags[which])))


def _same(a, b) -> bool:
    return a == b or (isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b))


def test_metrics_on_a_block_bag_equal_the_per_sample_bag_exactly(dtc_run):
    scenario, _, bags = dtc_run
    expected = evaluate_metrics(scenario, flatten_columns(load_columns(str(bags['per_sample']))))
    got = evaluate_metrics(scenario, flatten_columns(load_columns(str(bags['blocks']))))
    assert set(scenario.metrics) <= set(expected)
    assert all(isinstance(v, float) and math.isfinite(v) for v in expected.values()), expected
    assert expected.keys() == got.keys()
    assert all(_same(expected[k], got[k]) for k in expected), (expected, got)


def test_live_topics_alone_are_decimated_so_blocks_are_what_gets_read(dtc_run):
    """The block bag's recorded /plant/state is the 1 kHz live topic: reading it would lose samples."""
    _, samples, bags = dtc_run
    from drive_logger.bag_reader import BagReader
    counts = {t: i.message_count for t, i in BagReader(bags['blocks']).topics.items()}
    assert counts['/plant/state'] < len(samples.states) / 10
    assert len(load_columns(str(bags['blocks']))['/plant/state']['step']) == len(samples.states)


def test_blocks_that_skip_steps_are_refused(dtc_run, tmp_path):
    from drive_logger.bag_reader import BagReader
    from drive_logger.bag_writer import BagWriter
    from drive_logger.message_definitions import type_definition
    _, _, bags = dtc_run
    reader = BagReader(bags['blocks'])
    dropped = 0
    with BagWriter(tmp_path / 'gap') as writer:
        records = {name: writer.add_topic(name, type_definition(info.type), info.qos_profiles)
                   for name, info in reader.topics.items()}
        for msg in reader.messages():
            if msg.topic == '/dtc/status_block' and dropped == 0 and msg.log_time > 5_000_000:
                dropped += 1     # one block of samples lost
                continue
            writer.write(records[msg.topic], msg.data, msg.log_time, msg.publish_time)
    with pytest.raises(BagReadError, match='/dtc/status_block: steps skipped'):
        load_columns(str(tmp_path / 'gap'))
    # a topic not carried by the damaged block still reads
    assert '/plant/state' in load_columns(str(tmp_path / 'gap'), topics=('/plant/state',))
