"""The suite's order under pytest-xdist (conftest.py): the longest files first, the rest in place."""
import importlib.util
from pathlib import Path
from types import SimpleNamespace

ROOT = Path(__file__).resolve().parents[1]


def top_conftest():
    spec = importlib.util.spec_from_file_location('top_conftest', ROOT / 'conftest.py')
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_every_longest_first_file_exists():
    assert all((ROOT / path).is_file() for path in top_conftest().LONGEST_FIRST)


def test_a_worker_runs_the_longest_files_first_and_keeps_the_order_of_the_rest():
    conftest = top_conftest()
    first, second = conftest.LONGEST_FIRST[:2]
    ids = ['src/a/test/test_x.py::test_1', f'{second}::test_s', 'test/test_y.py::test_2',
           f'{first}::test_f', 'src/a/test/test_x.py::test_3']
    items = [SimpleNamespace(nodeid=i) for i in ids]
    conftest.pytest_collection_modifyitems(SimpleNamespace(workerinput={}), items)
    assert [i.nodeid for i in items] == [ids[3], ids[1], ids[0], ids[2], ids[4]]
    items = [SimpleNamespace(nodeid=i) for i in ids]
    conftest.pytest_collection_modifyitems(SimpleNamespace(), items)      # no xdist: unchanged
    assert [i.nodeid for i in items] == ids
