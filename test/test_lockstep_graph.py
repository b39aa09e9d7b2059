"""The lockstep graph as ROS users see it.

- ``node list``/``node info`` show /plant and the controllers with their
  real lockstep publishers and subscriptions (no helper nodes).
- One ``plant/run`` goal at a time: goals from two clients at once leave the
  plant up and its trajectory equal to a single client's (the headless
  co-simulation); a goal sent while a run is under way is rejected.
- Two graphs in one domain: every node refuses with a one-line error naming
  the domain (exit 2); a run under way is never finished as a success.
- The hand-started flow of docs/concepts.md ("Using the nodes"): the plant started first with ``run_until``,
  the controller seconds later: a real run (switching, torque at its
  reference), not the safe state.
"""
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest
from rclpy.action import ActionClient

from bldc_plant_sim.core.cosim import CoSimulation
from bldc_plant_sim.core.plant import PlantCore
from bldc_plant_sim.parameters import PLANT_SCHEMA
from drive_common.lockstep_io import listed_nodes
from drive_common.run_goal import run_to, send_run_goal
from drive_common import topics
from drive_testing.fixed_commands import FixedGateCore
from drive_testing.harness import send_until_answered, wait_until
from dtc_msgs.action import Run
from drive_testing.block_probe import BlockSamples, same_bits
from dtc_msgs.msg import PlantStateBlock

pytestmark = pytest.mark.ros

PATTERN = (True, False, False, True, False, False)
PLANT = {'motor.file': 'ozturk_bldc', 'dc_link.voltage': 10.0, 'motor.initial_speed': 20.0,
         'load.torque': 0.2, 'command_timeout': 10.0}
STARTUP_TIMEOUT = PLANT_SCHEMA.defaults()['startup_timeout']   # s, PLANT keeps the default
BACKEMF_TABLE = (Path(__file__).resolve().parents[1] / 'src' / 'bldc_plant_sim' / 'motors'
                 / 'ozturk_bldc_backemf.csv')


def _done(future, timeout: float, what: str):
    wait_until(future.done, timeout, what=what)
    return future.result()


def _states(session, name: str) -> list:
    """Every plant sample (plant/state_block) received by a new test node, once matched."""
    probe = BlockSamples(session.node(name), PlantStateBlock, topics.PLANT_STATE_BLOCK)
    wait_until(lambda: probe.subscription.get_publisher_count() >= 1, 30.0,
               what='plant/state_block matched')
    return probe.first


def _until_received(client, states: list, step_time: float = 0.0005, attempts: int = 20) -> int:
    """Run the plant in short goals until the probe holds a sample; the last goal's final step.

    The plant waits, before a run, only for the readers its own graph lists; on a
    loaded machine that list may still lack the probe and the first blocks are lost.
    Once one block arrived the writer has matched the probe's reader, and a reliable
    reader (BLOCK_DEPTH) loses no later sample.
    """
    for attempt in range(1, attempts + 1):
        result = run_to(client, attempt * step_time)
        assert result.success, result.message
        if wait_until(lambda: states, 5.0, raise_timeout=False):
            return result.final_step
    raise AssertionError(f'no plant/state_block sample reached the probe in {attempts} goals')


def _start_pair(start_node, **kwargs):
    responder = start_node('drive_testing', 'fixed_responder',
                           parameters={'switch_on': [float(s) for s in PATTERN]}, **kwargs)
    plant = start_node('bldc_plant_sim', 'plant', parameters=PLANT, **kwargs)
    return plant, responder


def test_node_info_shows_the_lockstep_topics_on_the_real_nodes(start_node, ros_session):
    _start_pair(start_node)
    node = ros_session.node('graph_probe')

    def names():
        return {name for name, _ in node.get_node_names_and_namespaces()}

    wait_until(lambda: {'plant', 'fixed_responder'} <= names(), 30.0, what='both nodes')

    def topics_of(kind, name):
        found = getattr(node, f'get_{kind}_names_and_types_by_node')(name, '/')
        return {topic for topic, _ in found}

    # Each endpoint reaches the graph cache in its own discovery message: wait for all.
    wait_until(lambda: {'/drive/gate_command', '/pfc/duty_command'} <= topics_of('subscriber', 'plant')
               and '/drive/measurement' in topics_of('subscriber', 'fixed_responder')
               and {'/drive/measurement', '/pfc/measurement', '/plant/state', '/clock'}
               <= topics_of('publisher', 'plant')
               and '/drive/gate_command' in topics_of('publisher', 'fixed_responder'), 30.0,
               what='lockstep endpoints of /plant and /fixed_responder')
    assert not [n for n in names() if 'lockstep' in n], names()
    # The graph still works: the executor does not take the directly received messages.
    client = ActionClient(node, Run, topics.RUN_ACTION)
    wait_until(client.server_is_ready, 30.0, what='plant/run')
    result = run_to(client, 0.002)
    assert result.success and result.final_step == 80, result.message


def test_concurrent_goals_run_one_at_a_time_and_the_trajectory_is_a_single_clients(
        start_node, ros_session):
    plant, _ = _start_pair(start_node)
    states = _states(ros_session, 'state_probe')
    clients = [ActionClient(ros_session.node(f'client_{i}'), Run, topics.RUN_ACTION)
               for i in range(2)]
    for client in clients:
        wait_until(client.server_is_ready, 30.0, what='plant/run')
    # Both clients at once, each asking for the same absolute time.
    with ThreadPoolExecutor(2) as pool:
        handles = list(pool.map(lambda client: send_run_goal(client, 0.01), clients))
    accepted = [h for h in handles if h.accepted]
    assert accepted, 'no goal accepted'
    results = [_done(h.get_result_async(), 120.0, 'result').result for h in accepted]
    assert all(r.success and r.final_step == 400 for r in results), [r.message for r in results]
    # A goal sent while a run is under way is rejected (the stated policy), and the
    # plant logs why. The run is long (1 s of sim time, cancelled below) so that it is still
    # under way if the third goal's reply is slow and the goal is sent again.
    long_run = send_run_goal(clients[0], 1.0)
    assert long_run.accepted
    wait_until(lambda: states and states[-1].step > 420, 60.0, what='long run under way')
    third = send_run_goal(clients[1], 0.02)
    assert not third.accepted
    assert _done(long_run.cancel_goal_async(), 30.0, 'cancel').goals_canceling
    assert not _done(long_run.get_result_async(), 120.0, 'cancelled result').result.success
    assert plant.alive(), plant.output()[-2000:]
    wait_until(lambda: 'another run holds the plant' in plant.output(), 10.0,
               what='the rejection reason in the plant log')

    trajectory = CoSimulation(PlantCore(PLANT), FixedGateCore(PATTERN), record_every=1).run(steps=400)
    by_step = {s.step: s for s in states if s.step <= 400}
    assert set(range(0, 401)) <= set(by_step), 'a ground-truth sample is missing'
    for step, truth in zip(trajectory.steps, trajectory.states):
        assert list(by_step[step].phase_current) == list(truth.phase_current), step
        assert by_step[step].electromagnetic_torque == truth.electromagnetic_torque, step


def test_a_relative_goal_whose_reply_is_lost_runs_once(start_node, ros_session):
    """The reply to an accepted goal is dropped on the client side (as Fast DDS drops it when
    the server's reply writer has not matched yet): the goal is recognised from the action's
    status topic, its result arrives, and the plant ran it once, not again."""
    from drive_common.run_goal import run_goal_result
    _start_pair(start_node)
    client = ActionClient(ros_session.node('client'), Run, topics.RUN_ACTION)
    wait_until(client.server_is_ready, 30.0, what='plant/run')
    original = client.send_goal_async
    dropped = []

    def send_and_lose_the_first_reply(goal, feedback_callback=None, goal_uuid=None):
        future = original(goal, feedback_callback=feedback_callback, goal_uuid=goal_uuid)
        if not dropped:
            (sequence,) = [k for k, f in client._pending_goal_requests.items() if f is future]
            dropped.append(client._goal_sequence_number_to_goal_id.pop(sequence))  # reply ignored
        return future

    client.send_goal_async = send_and_lose_the_first_reply
    handle = send_run_goal(client, 0.001, relative=True)
    assert dropped and handle.accepted and handle.goal_id == dropped[0]
    first = run_goal_result(handle)
    assert first.success and first.final_step == 40, first.message          # 0.001 s once, not twice
    second = run_to(client, 0.001, relative=True)
    assert second.success and second.final_step == 80, second.message


def _refused_with_domain(process, domain: int) -> bool:
    """Exited 2 with a one-line error naming the domain, no traceback."""
    out = process.output()
    return (process.process.returncode == 2 and f'in ROS domain {domain}:' in out
            and 'Traceback' not in out)


def _headless_equal(states, steps: int) -> int:
    """Compare received plant/state with the headless co-simulation; the number compared."""
    trajectory = CoSimulation(PlantCore(PLANT), FixedGateCore(PATTERN), record_every=1).run(steps=steps)
    by_step = {s.step: s for s in states}
    compared = 0
    for step, truth in zip(trajectory.steps, trajectory.states):
        if step in by_step:
            assert list(by_step[step].phase_current) == list(truth.phase_current), step
            compared += 1
    return compared


def test_two_graphs_in_one_domain_refuse_and_never_give_a_silent_wrong_result(
        start_node, ros_session, ros_domain, tmp_path):
    plant_a, responder_a = _start_pair(start_node)
    states = _states(ros_session, 'state_probe')
    client = ActionClient(ros_session.node('client'), Run, topics.RUN_ACTION)
    wait_until(client.server_is_ready, 30.0, what='plant/run')
    warmed_up = _until_received(client, states)   # the comparison below needs (almost) every sample
    handle = send_run_goal(client, 0.2)
    assert handle.accepted
    result = handle.get_result_async()
    wait_until(lambda: states[-1].step > warmed_up + 100, 60.0, what='run of graph A under way')
    plant_b, responder_b = _start_pair(start_node, log_dir=tmp_path / 'graph_b')  # same domain
    processes = (plant_a, responder_a, plant_b, responder_b)

    # Settled: A's run ended (or its plant refused), and at most one node of each name is left.
    wait_until(lambda: result.done() or not plant_a.alive(), 120.0, what='run of graph A to end')
    probe = ros_session.node('name_probe')

    seen: dict = {}

    def settled() -> bool:
        """At most one live process per node name, and its node (only) in the graph."""
        names = [n for n, _ in listed_nodes(probe)]     # (rmw may keep a departed node)
        alive = {'plant': sum(p.alive() for p in (plant_a, plant_b)),
                 'fixed_responder': sum(p.alive() for p in (responder_a, responder_b))}
        seen.update(graph=sorted(names), alive=alive)
        return all(count <= 1 and names.count(name) == count for name, count in alive.items())

    assert wait_until(settled, 60.0, raise_timeout=False), f'not one graph left in 60 s: {seen}'
    refused = [p for p in processes if not p.alive()]
    assert refused, 'nobody noticed the second graph'
    for process in refused:
        process.process.wait(timeout=10)
        assert _refused_with_domain(process, ros_domain), process.output()[-2000:]
    # Never a silent wrong result: a run that succeeded equals a single graph's run.
    if result.done() and result.result().result.success:
        # The result can come before the probe has taken the run's last blocks (a loaded
        # test process): every sample up to the final step is there once the last one is.
        final_step = result.result().result.final_step
        wait_until(lambda: states[-1].step >= final_step, 60.0, what='the last plant sample')
        assert _headless_equal([s for s in states if s.step <= 8000], 8000) > 7000
    # What is left of the two graphs runs correctly, or fails: never a wrong success.
    if plant_b.alive():
        probe_b = BlockSamples(ros_session.node('state_probe_b'), PlantStateBlock,
                               topics.PLANT_STATE_BLOCK)
        states_b, sub = probe_b.first, probe_b.subscription
        wait_until(lambda: sub.get_publisher_count() >= 1 or not plant_b.alive(), 30.0)
        client_b = ActionClient(ros_session.node('client_b'), Run, topics.RUN_ACTION)
        wait_until(lambda: client_b.server_is_ready() or not plant_b.alive(), 30.0)
        sent = client_b.send_goal_async(Run.Goal(target_time=0.002))
        wait_until(lambda: sent.done() or not plant_b.alive(), 60.0, what='goal response from B')
        if sent.done() and sent.result().accepted:
            answer = sent.result().get_result_async()
            # B's plant may wait its whole startup_timeout for a controller that refused to run.
            wait_until(lambda: answer.done() or not plant_b.alive(), STARTUP_TIMEOUT + 30.0,
                       what='result from B')
            if answer.done() and answer.result().result.success:
                wait_until(lambda: states_b and states_b[-1].step == 80, 30.0, what='B at 80')
                assert _headless_equal(states_b, 80) >= 1
        if not plant_b.alive():
            plant_b.process.wait(timeout=10)
            assert _refused_with_domain(plant_b, ros_domain), plant_b.output()[-2000:]


def test_hand_started_flow_controller_seconds_after_the_plant_makes_a_real_run(
        start_node, ros_session):
    """docs/concepts.md: terminal 1 starts the plant with run_until, terminal 2 the controller later."""
    states = BlockSamples(ros_session.node('state_probe'), PlantStateBlock,
                          topics.PLANT_STATE_BLOCK).first
    plant = start_node('bldc_plant_sim', 'plant',
                       parameters={'motor.file': 'ozturk_bldc', 'dc_link.voltage': 56.57,
                                   'run_until': 0.05})
    # The plant waits, and says for what, until the controller is there (several seconds:
    # its second "waiting" line comes WAIT_LOG_PERIOD after the first).
    wait_until(lambda: plant.output().count('waiting') >= 2, 60.0, what='plant waiting for 6 s')
    assert 'drive/gate_command' in plant.output() and plant.alive()
    start_node('dtc_controller', 'dtc_controller',
               parameters={'mode': 'two_phase_six_switch', 'backemf_table_path': str(BACKEMF_TABLE),
                           'torque_reference': 0.5})
    wait_until(lambda: 'run_until finished' in plant.output(), 180.0, what='the run to finish')
    out = plant.output()
    assert 'safe state' not in out and 'reached t = 0.050000 s' in out, out[-3000:]
    wait_until(lambda: states and states[-1].step == 2000, 30.0, what='the last state')
    run = [s for s in states if s.step >= 1000]             # the second half of the run
    assert not any(s.safe_state for s in states)
    patterns = {tuple(s.applied_switch_on) for s in run}
    assert len(patterns) >= 3, patterns                      # the inverter switched
    mean_torque = sum(s.electromagnetic_torque for s in run) / len(run)
    assert 0.4 < mean_torque < 0.6, mean_torque              # T* = 0.5 N m


def test_a_matched_controller_that_never_answers_is_not_ready(start_node, ros_session):
    """Matching alone does not start sim time: the first measurement must be answered."""
    from dtc_msgs.msg import DriveMeasurement, GateCommand
    node = ros_session.node('silent_controller')
    seen = []
    sub = node.create_subscription(DriveMeasurement, topics.DRIVE_MEASUREMENT, seen.append,
                                   topics.LOCKSTEP_QOS)
    pub = node.create_publisher(GateCommand, topics.GATE_COMMAND, topics.LOCKSTEP_QOS)
    plant = start_node('bldc_plant_sim', 'plant',
                       parameters={**PLANT, 'startup_timeout': 3.0, 'run_until': 0.01})
    wait_until(lambda: 'run_until finished' in plant.output(), 60.0, what='the run to give up')
    out = plant.output()
    assert 'did not answer its first measurement (step 0) within startup_timeout = 3 s' in out, out
    assert 'run_until finished: run not started: ' in out and 'ended normally' not in out, out
    assert seen and all(m.step == 0 for m in seen)        # only step 0 went out (re-sent)
    assert 'reached t =' not in out and plant.alive()    # sim time never started
    # A real controller later: the next run starts, switching (no safe state left over).
    node.destroy_subscription(sub)
    node.destroy_publisher(pub)
    start_node('drive_testing', 'fixed_responder',
               parameters={'switch_on': [float(s) for s in PATTERN]})
    states = _states(ros_session, 'state_probe')
    client = ActionClient(ros_session.node('client'), Run, topics.RUN_ACTION)
    wait_until(client.server_is_ready, 30.0, what='plant/run')
    # The goal once the controller's endpoints are in the graph (the plant's startup_timeout
    # is only 3 s, less than a node's start on a loaded machine).
    wait_until(lambda: node.count_subscribers(topics.DRIVE_MEASUREMENT) >= 1
               and node.count_publishers(topics.GATE_COMMAND) >= 1, 60.0, what='fixed_responder up')
    result = run_to(client, 0.002)
    assert result.success and result.final_step == 80, result.message
    wait_until(lambda: states and states[-1].step == 80, 30.0, what='the last state')
    assert not states[-1].safe_state and list(states[-1].applied_switch_on) == list(PATTERN)


def test_dtc_status_blocks_carry_every_sample_bit_exact_across_holds(start_node, ros_session):
    """Plant + dtc_controller: both nodes' blocks equal the headless co-simulation sample for
    sample (status, the measurement it acted on, the command it sent), across a hold and a
    second goal; partial blocks go out at the hold; the live topics carry every 10th sample."""
    from dtc_controller.core.controller import DtcCore
    from dtc_controller.parameters import DTC_SCHEMA
    from dtc_msgs.msg import DtcStatus, DtcStatusBlock
    telemetry = {'telemetry.block_size': 7, 'telemetry.live_period': 250e-6}
    dtc = {'mode': 'two_phase_six_switch', 'backemf_table_path': str(BACKEMF_TABLE),
           'torque_reference': 0.5}
    # The readers exist before the nodes start: a node waits, before its first sample, for the
    # readers its graph already lists; one that joined later can miss the first blocks.
    node = ros_session.node('block_probe')
    plant_blocks = BlockSamples(node, PlantStateBlock, topics.PLANT_STATE_BLOCK)
    status_blocks = BlockSamples(node, DtcStatusBlock, topics.DTC_STATUS_BLOCK)
    live: list = []
    node.create_subscription(DtcStatus, topics.DTC_STATUS, live.append, topics.STREAM_QOS)
    start_node('dtc_controller', 'dtc_controller', parameters={**dtc, **telemetry})
    start_node('bldc_plant_sim', 'plant', parameters={**PLANT, **telemetry})
    wait_until(lambda: status_blocks.subscription.get_publisher_count() >= 1
               and plant_blocks.subscription.get_publisher_count() >= 1, 30.0, what='block topics')
    client = ActionClient(node, Run, topics.RUN_ACTION)
    wait_until(client.server_is_ready, 30.0, what='plant/run')
    for target, last in ((0.0031, 123), (0.0041, 163)):      # a hold at step 124, then 164
        result = run_to(client, target)
        assert result.success, result.message
        wait_until(lambda: status_blocks.records and status_blocks.records[-1][0].step == last,
                   30.0, what=f'status block flushed at the hold (step {last})')
    wait_until(lambda: plant_blocks.first and plant_blocks.first[-1].step == 164, 30.0,
               what='plant block flushed at step 164')

    measurements = []

    class Recorded(DtcCore):
        def update(self, sample):
            measurements.append(sample)
            return super().update(sample)

    trajectory = CoSimulation(PlantCore(PLANT), Recorded(DTC_SCHEMA.resolve(dtc)),
                              record_every=1).run(steps=164)
    # Every sample once (none lost, none doubled by the holds), bit-exact.
    assert [s.step for s in plant_blocks.first] == list(range(165))
    for state in plant_blocks.first:
        assert same_bits(state, trajectory.states[state.step]), state.step
    assert [r[0].step for r in status_blocks.records] == list(range(164))
    assert max(b.count for b in status_blocks.blocks) == 7
    for status, measurement, command in status_blocks.records:
        k = status.step
        assert status.header.stamp.nanosec == measurement.header.stamp.nanosec == 25_000 * k
        assert same_bits(status, trajectory.dtc_status[k]), k
        assert same_bits(measurement, measurements[k]), k
        assert same_bits(command, trajectory.commands[k][0]), k
    assert len({tuple(c.switch_on) for _, _, c in status_blocks.records}) >= 2   # it switched
    wait_until(lambda: live and live[-1].step == 160, 30.0, what='live status 160')
    assert [s.step for s in live] == list(range(0, 161, 10))
    for status in live:
        assert same_bits(status, trajectory.dtc_status[status.step]), status.step


def test_a_repeated_measurement_is_answered_again_without_a_second_core_update(
        start_node, ros_session):
    from drive_testing.block_probe import message_bits
    from dtc_msgs.msg import DriveMeasurement, DtcStatus, DtcStatusBlock, GateCommand
    start_node('dtc_controller', 'dtc_controller',
               parameters={'backemf_table_path': str(BACKEMF_TABLE), 'torque_reference': 0.5,
                           'telemetry.live_period': 0.0})
    node = ros_session.node('resender')
    gates, statuses = [], []
    blocks = BlockSamples(node, DtcStatusBlock, topics.DTC_STATUS_BLOCK)
    pub = node.create_publisher(DriveMeasurement, topics.DRIVE_MEASUREMENT, topics.LOCKSTEP_QOS)
    node.create_subscription(GateCommand, topics.GATE_COMMAND, gates.append, topics.LOCKSTEP_QOS)
    node.create_subscription(DtcStatus, topics.DTC_STATUS, statuses.append, topics.STREAM_QOS)
    wait_until(lambda: pub.get_subscription_count() >= 1
               and node.count_publishers(topics.DTC_STATUS) >= 1, 30.0, what='controller')
    msg = DriveMeasurement(step=0, dc_link_voltage=56.57, midpoint_voltage=28.28,
                           encoder_angle=0.3, mechanical_speed=30.0, hall_code=1)
    msg.phase_current = [2.0, -2.0, 0.0]
    first = message_bits(msg)
    send_until_answered(lambda: pub.publish(msg), lambda: gates, what='first answer')
    wait_until(lambda: statuses, 30.0, what='the first status')
    # Earlier re-sends may still be answered (a slow first answer is re-sent): wait for more.
    answers = len(gates)
    pub.publish(msg)                                       # the plant re-sends it
    wait_until(lambda: len(gates) > answers, 30.0, what='the repeated answer')
    assert all(g == gates[0] for g in gates)
    assert len(statuses) == 1                              # re-sends update the core once
    msg.step, msg.hold_after = 1, True                      # the last sample before a hold
    pub.publish(msg)
    wait_until(lambda: len(statuses) == 2, 30.0, what='answer to step 1')
    assert [s.step for s in statuses] == [0, 1]           # one core update per step
    # The status block (flushed after the sample marked hold_after): one sample per core
    # update, each with the measurement it acted on and the command it sent, bit-exact.
    wait_until(lambda: len(blocks.records) >= 2, 30.0, what='the status blocks')
    assert [status.step for status, _, _ in blocks.records] == [0, 1]
    (status, measurement, command), _ = blocks.records
    assert message_bits(measurement) == first
    assert message_bits(command) == message_bits(gates[0])
    assert message_bits(status) == message_bits(statuses[0])


def test_a_subscriber_that_never_matches_is_named_and_does_not_stop_the_run(start_node, ros_session):
    """A reader the plant's writer can never match (here: it asks for transient-local data of a
    volatile topic; also a reader whose process left but is still listed) is named while the
    plant waits for the graph's readers, then left behind: the run starts and completes."""
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
    deaf = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                      durability=DurabilityPolicy.TRANSIENT_LOCAL)
    node = ros_session.node('deaf_reader')
    node.create_subscription(PlantStateBlock, topics.PLANT_STATE_BLOCK, lambda _: None, deaf)
    start_node('drive_testing', 'fixed_responder', parameters={'switch_on': [float(s) for s in PATTERN]})
    wait_until(lambda: node.count_publishers(topics.GATE_COMMAND) >= 1, 60.0, what='fixed_responder up')
    plant = start_node('bldc_plant_sim', 'plant',
                       parameters={**PLANT, 'startup_timeout': 10.0, 'run_until': 0.002})
    wait_until(lambda: 'run_until finished' in plant.output(), 120.0, what='the run to end')
    out = plant.output()
    assert 'for the subscribers in the graph to match: /plant/state_block' in out, out
    assert ('subscriber(s) of /plant/state_block did not match the plant within 20 s' in out
            and 'the run starts without them' in out), out
    # The wait for readers is not counted against startup_timeout (10 s here, half of it).
    assert 'reached t = 0.002000 s (step 80); ended normally' in out, out
