"""The fault-injection matrix as a test: every fault kind, injected into real short runs through
the graph and the headless runner, is reported as its kind requires; none is silent, none
crashes a node or hangs a run, and no outsider changes a run's recorded drive data."""
import pytest

from drive_testing.fault_matrix import cases, run_matrix, table

pytestmark = [pytest.mark.ros, pytest.mark.timeout(1800)]


def test_every_injected_fault_is_reported_and_no_outsider_changes_a_run(tmp_path):
    outcomes = run_matrix(tmp_path, workers=2)    # two cases at once: a loaded machine too
    print(table(outcomes))
    assert len(outcomes) == len(cases())
    assert {o.expect for o in outcomes} == {'fault', 'outsider', 'refused', 'node lost'}
    assert [o.case for o in outcomes if o.silent] == []
    assert [(o.case, o.where, o.crashed) for o in outcomes if o.crashed] == []
    assert [o.case for o in outcomes if o.changed] == []
    assert [(o.case, o.where) for o in outcomes if not o.reported] == []
    outsiders = [o for o in outcomes if o.expect in ('outsider', 'refused')]
    assert outsiders and all(o.changed is False for o in outsiders)   # each was compared
