"""A whole number given for a double parameter is taken as that double, at start-up
(``-p run_until:=20``) and at runtime (``ros2 param set /plant load.torque 1``); a value of
another type is still refused with the reason, and the old value kept."""
import pytest
import rclpy
from rclpy.parameter import Parameter

from drive_common.parameters import ParameterSpec, schema
from drive_common.processes import reserve_domain
from drive_common.ros_parameters import SchemaParameters

pytestmark = pytest.mark.ros

SCHEMA = schema([
    ParameterSpec('run_until', 0.0, 'run to this sim time', unit='s', min_value=0.0),
    ParameterSpec('offsets', [0.0, 0.0, 0.0], 'sensor offsets', unit='A', length=3),
    ParameterSpec('count', 2, 'an integer', min_value=0),
])


@pytest.fixture
def node():
    with reserve_domain() as domain_id:
        context = rclpy.Context()
        rclpy.init(context=context, domain_id=domain_id)
        node = rclpy.create_node('typed', context=context, cli_args=[
            '--ros-args', '-p', 'run_until:=20', '-p', 'offsets:=[1, 2, 3]', '-p', 'count:=3'])
        try:
            yield node
        finally:
            node.destroy_node()
            rclpy.try_shutdown(context=context)


def test_whole_numbers_start_and_change_double_parameters_as_doubles(node):
    params = SchemaParameters(node, SCHEMA)
    assert node.get_parameter('run_until').type_ == Parameter.Type.DOUBLE
    assert params['run_until'] == 20.0 and params['offsets'] == [1.0, 2.0, 3.0]
    assert node.get_parameter('offsets').type_ == Parameter.Type.DOUBLE_ARRAY
    assert node.get_parameter('count').type_ == Parameter.Type.INTEGER and params['count'] == 3

    seen = []
    params.add_pre_set(lambda changes: seen.extend(p.type_ for p in changes) or changes)
    result = node.set_parameters([Parameter('run_until', value=7)])[0]
    assert result.successful, result.reason
    assert node.get_parameter('run_until').value == 7.0 and params['run_until'] == 7.0
    result = node.set_parameters([Parameter('offsets', value=[0, 5, 0])])[0]
    assert result.successful and params['offsets'] == [0.0, 5.0, 0.0]
    # A node's own pre-set hook (the plant's motor-file merge) sees the doubles, once each.
    assert seen == [Parameter.Type.DOUBLE, Parameter.Type.DOUBLE_ARRAY]


def test_other_types_are_still_refused_and_keep_the_old_value(node):
    params = SchemaParameters(node, SCHEMA)
    for name, value in (('run_until', 'high'), ('count', 2.5), ('run_until', -1)):
        result = node.set_parameters([Parameter(name, value=value)])[0]
        assert not result.successful and result.reason, (name, value)
    assert params['run_until'] == 20.0 and params['count'] == 3
    assert node.get_parameter('run_until').value == 20.0
