"""pytest fixtures of the launch-free harness (enabled by the top-level conftest.py).

``ros_domain`` (a reserved ROS_DOMAIN_ID), ``ros_session`` (an rclpy context in it, spinning)
and ``start_node`` (a node process as ``ros2 run`` starts it; stopped at teardown, its output
printed, after its threads' stacks if the test failed).
"""
from __future__ import annotations

import pytest

from drive_testing.harness import NodeProcess, RosSession, isolated_env, reserve_domain


@pytest.fixture
def ros_domain():
    with reserve_domain() as domain_id:
        yield domain_id


@pytest.fixture
def ros_session(ros_domain):
    session = RosSession(ros_domain)
    try:
        yield session
    finally:
        session.close()


CALL_FAILED = pytest.StashKey[bool]()


@pytest.hookimpl(wrapper=True)
def pytest_runtest_makereport(item, call):
    """Mark a test whose call failed, for the teardown of :func:`start_node`."""
    report = yield
    if report.when == 'call' and report.failed:
        item.stash[CALL_FAILED] = True
    return report


@pytest.fixture
def start_node(ros_domain, tmp_path, request):
    processes: list[NodeProcess] = []

    def _start(package: str, executable: str, **kwargs) -> NodeProcess:
        kwargs.setdefault('env', isolated_env(ros_domain))
        kwargs.setdefault('log_dir', tmp_path / 'nodes')
        process = NodeProcess(package, executable, **kwargs)
        processes.append(process)
        return process

    try:
        yield _start
    finally:
        failed = request.node.stash.get(CALL_FAILED, False)
        # A failed test: where each node it may have waited on was, before it is stopped.
        dumped = {id(p) for p in processes if failed and p.dump_stacks(wait=5.0)}
        for process in processes:
            process.stop()
            print(f'----- {process.package}/{process.executable} (exit {process.process.returncode}) -----')
            print(process.output()[-16000 if id(process) in dumped else -4000:])
