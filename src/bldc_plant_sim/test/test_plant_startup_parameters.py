"""The plant declares a motor file's values at start-up instead of setting them afterwards: a
change event published at start-up reaches a recorder or not depending on discovery timing,
so two recordings of one scenario would differ."""
from __future__ import annotations

import pytest
from rclpy.parameter import Parameter

from bldc_plant_sim.parameters import PLANT_SCHEMA, effective_params, load_motor_file
from drive_testing.harness import private_domain

MOTOR_FILE = 'ozturk_bldc_nonideal'


def _plain(value):
    return list(value) if isinstance(value, (list, tuple)) or hasattr(value, 'tolist') else value


@pytest.mark.ros
def test_a_motor_files_values_are_declared_not_set_at_start_up(monkeypatch):
    from bldc_plant_sim.plant_node import PlantNode
    sets: list[list[str]] = []
    original = PlantNode.set_parameters_atomically

    def counted(self, parameters):
        sets.append([p.name for p in parameters])
        return original(self, parameters)

    monkeypatch.setattr(PlantNode, 'set_parameters_atomically', counted)
    with private_domain() as domain:
        plant = PlantNode(context=domain.context, start_parameter_services=False,
                          parameter_overrides=[Parameter('motor.file', value=MOTOR_FILE),
                                               Parameter('motor.resistance', value=1.25)])
        try:
            declared = {name: _plain(plant.get_parameter(name).value)
                        for name in load_motor_file(MOTOR_FILE)}
            used = effective_params({'motor.file': MOTOR_FILE, 'motor.resistance': 1.25},
                                    explicit={'motor.file', 'motor.resistance'})
            assert sets == []                                   # nothing set after the declaration
            assert plant.get_parameter('motor.resistance').value == 1.25   # given: beats the file
            assert declared == {name: _plain(used[name]) for name in declared}
            # not vacuous: the file changes values from the schema's defaults
            assert any(declared[n] != _plain(PLANT_SCHEMA[n].default) for n in declared)
        finally:
            plant.destroy_node()
