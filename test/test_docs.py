"""The documentation site and the README.

- the site builds with warnings as errors (bash scripts/docs.sh) and its
  reference pages hold every node parameter and message field the code declares;
- the README stays short and links only to pages that exist;
- no internal workflow words (tracker numbers, "formerly") in src, test,
  benchmarks, docs or the README;
- the runnable code blocks of the tutorials (MyST ``{code-block} bash`` with
  ``:class: run``, docs/getting_started.md "Code blocks that are run") run, each
  in a fresh ``bash`` from the repository root, sharing one ``TMPDIR`` per page.
"""
from __future__ import annotations

import os
import re
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / 'docs'
HTML = DOCS / '_build' / 'html'
TUTORIALS = ['getting_started.md', 'scenarios.md', 'write_your_own_controller.md']
WORKFLOW_WORDS = re.compile(r'\bissue *[#-]? *\d+|\bformerly\b', re.IGNORECASE)
RUN_BLOCK = re.compile(r'^```\{code-block\} bash\n((?::[\w-]+:[^\n]*\n)*)\n?(.*?)^```$', re.MULTILINE | re.DOTALL)


def run_blocks(page: Path) -> list[str]:
    """The bodies of the page's ``{code-block} bash`` blocks marked ``:class: run``, in order."""
    return [body for options, body in RUN_BLOCK.findall(page.read_text())
            if re.search(r'^:class:.*\brun\b', options, re.MULTILINE)]


@pytest.fixture(scope='module')
def built_site():
    result = subprocess.run(['bash', 'scripts/docs.sh'], cwd=ROOT, capture_output=True, text=True, timeout=900)
    assert result.returncode == 0, f'docs build failed:\n{result.stdout[-4000:]}\n{result.stderr[-4000:]}'
    return HTML


def test_site_builds_without_warnings(built_site):
    for page in ['index', 'getting_started', 'concepts', 'scenarios', 'reproduction', 'benchmarks',
                 'live_view', 'multi_host', 'write_your_own_controller', 'bags', 'faults',
                 'reference/nodes', 'reference/messages', 'reference/api']:
        assert (built_site / f'{page}.html').is_file(), page


def test_reference_holds_every_parameter_and_field(built_site):
    """Generated, so it cannot drift: every schema name and every message field is on its page."""
    from bldc_plant_sim.parameters import PLANT_SCHEMA
    from drive_logger.live_view import LIVE_VIEW_SCHEMA
    from drive_logger.recorder_node import RECORDER_SCHEMA
    from drive_logger.replay_node import REPLAY_SCHEMA
    from dtc_controller.parameters import DTC_SCHEMA
    from pfc_controller.parameters import PFC_SCHEMA
    nodes = (built_site / 'reference/nodes.html').read_text()
    for schema in (PLANT_SCHEMA, DTC_SCHEMA, PFC_SCHEMA, RECORDER_SCHEMA, REPLAY_SCHEMA, LIVE_VIEW_SCHEMA):
        for name in schema.names():
            assert f'<code class="docutils literal notranslate"><span class="pre">{name}</span>' in nodes, name
    assert 'port' in nodes and 'plant/run' in nodes and 'dtc_msgs/action/Run' in nodes
    messages = (built_site / 'reference/messages.html').read_text()
    for path in sorted((ROOT / 'src/dtc_msgs').glob('*/*.*')):
        for line in path.read_text().splitlines():
            code = line.split('#', 1)[0].split()
            if len(code) >= 2 and code[0] != '---':
                name = code[1].split('=')[0]
                assert f'<span class="pre">{name}</span>' in messages, f'{path.name}: {name}'
    scenarios = (built_site / 'scenarios.html').read_text()
    for path in (ROOT / 'src/drive_bringup/scenarios').glob('*.yaml'):
        assert path.stem in scenarios, path.stem


def test_metrics_page_names_every_registered_metric():
    """docs/reference/metrics.md is written by hand: every metric a scenario can name is on it."""
    from drive_analysis.registry import metrics
    named = set(re.findall(r'`(\w+)`', (DOCS / 'reference/metrics.md').read_text()))
    missing = sorted(set(metrics()) - named)
    assert not missing, f'metrics not described in docs/reference/metrics.md: {missing}'


def test_study_file_example_loads(tmp_path):
    """The annotated study file of docs/studies.md is a valid study (every key, target and metric)."""
    from drive_bringup.study import load_study
    block = re.search(r'^## The study file\n\n```yaml\n(.*?)^```$', (DOCS / 'studies.md').read_text(),
                      re.MULTILINE | re.DOTALL)
    assert block, 'docs/studies.md has no study file example'
    (tmp_path / 'my_study.yaml').write_text(block.group(1))
    study = load_study(tmp_path / 'my_study.yaml')
    assert study.name == 'my_study'


def test_readme_is_short_and_links_to_existing_pages():
    text = (ROOT / 'README.md').read_text()
    assert len(text.splitlines()) <= 150
    links = re.findall(r'\]\(((?:docs/)[^)#]+)', text)
    assert 'docs/getting_started.md' in links and 'docs/reference/index.md' in links
    for link in links:
        assert (ROOT / link).exists(), link


def test_no_workflow_words():
    found = []
    for top in ['src', 'test', 'benchmarks', 'docs', 'README.md']:
        base = ROOT / top
        paths = [base] if base.is_file() else [p for p in base.rglob('*') if p.is_file()]
        for path in paths:
            if any(part in {'_build', '_generated', '__pycache__'} for part in path.parts) \
                    or path.suffix in {'.png', '.parquet', '.pyc', '.mcap'}:
                continue
            try:
                text = path.read_text()
            except UnicodeDecodeError:
                continue
            for n, line in enumerate(text.splitlines(), 1):
                if WORKFLOW_WORDS.search(line) and path != Path(__file__):
                    found.append(f'{path.relative_to(ROOT)}:{n}: {line.strip()}')
    assert not found, 'internal workflow words:\n' + '\n'.join(found)


def test_workflow_word_pattern():
    for bad in ['see issue 14', 'Issue 7: a run', '(ISSUE-3)', 'issue #2', 'formerly drive_logger analyze']:
        assert WORKFLOW_WORDS.search(bad), bad
    for fine in ['an issue with the link', 'formal', 'tissue 3']:
        assert not WORKFLOW_WORDS.search(fine), fine


def test_run_blocks_are_found():
    blocks = run_blocks(DOCS / 'getting_started.md')
    assert len(blocks) >= 2 and 'run_scenario' in blocks[1]


@pytest.mark.parametrize('page', TUTORIALS)
def test_tutorial_code_blocks_run(page, tmp_path):
    """Each runnable block of the page, in order, in a fresh bash -e from the repository root."""
    blocks = run_blocks(DOCS / page)
    assert blocks, f'{page} has no runnable block'
    env = dict(os.environ, TMPDIR=str(tmp_path))
    for block in blocks:
        script = 'set -eo pipefail\n' + block
        result = subprocess.run(['bash', '-c', script], cwd=ROOT, env=env, capture_output=True, text=True,
                                timeout=900)
        assert result.returncode == 0, (f'{page}: exit {result.returncode}\n--- block\n{block}\n'
                                        f'--- stdout\n{result.stdout[-3000:]}\n--- stderr\n{result.stderr[-3000:]}')


def test_reproduce_writes_the_docs_page_between_its_markers(tmp_path):
    """`reproduce --docs PAGE` replaces only the table between the markers; a page without them is refused."""
    from drive_bringup import reproduce
    page = tmp_path / 'reproduction.md'
    page.write_text(f'# Page\n\nbefore\n\n{reproduce.BEGIN}\nold table\n{reproduce.END}\n\nafter\n')
    code = reproduce.main(['--only', 'example_hysteresis', '--jobs', '1', '--out', str(tmp_path / 'reports'),
                           '--docs', str(page)])
    assert code == 0
    text = page.read_text()
    assert text.startswith('# Page\n\nbefore\n\n') and text.endswith(f'{reproduce.END}\n\nafter\n')
    assert 'old table' not in text and '| example_hysteresis_current_control |' in text
    assert '2/2 checks pass' in text
    bare = tmp_path / 'bare.md'
    bare.write_text('no markers\n')
    with pytest.raises(SystemExit, match='markers'):
        reproduce.main(['--only', 'example_hysteresis', '--docs', str(bare)])
    assert reproduce.BEGIN in (DOCS / 'reproduction.md').read_text()
