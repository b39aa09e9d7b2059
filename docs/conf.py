"""Sphinx configuration of the documentation site (bash scripts/docs.sh -> docs/_build/html).

MyST Markdown pages, the furo theme, autodoc of the ROS-agnostic cores (build
with the workspace sourced: `source scripts/env.sh`), and the local extension
docs/_ext/drive_reference.py, which generates the node, message and scenario
reference from the code at every build.
"""
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent / '_ext'))

project = 'DTC drive stack for ROS 2 Jazzy'
author = 'DTC drive stack contributors'
extensions = ['myst_parser', 'sphinx.ext.autodoc', 'sphinx.ext.napoleon', 'drive_reference']
source_suffix = {'.md': 'markdown'}
myst_enable_extensions = ['colon_fence', 'deflist']
myst_heading_anchors = 3
html_theme = 'furo'
html_title = 'DTC drive stack'
exclude_patterns = ['_build', 'reference/_generated', 'studies/*/comparison.md']  # a study's output, shown as a file
suppress_warnings = ['myst.xref_missing']
autodoc_member_order = 'bysource'
autodoc_typehints = 'description'
autodoc_default_options = {'members': True, 'show-inheritance': False}
nitpicky = False


def _plain_docstrings(app, what, name, obj, options, lines):
    """Show a docstring written as plain text (not reStructuredText) as preformatted text.

    The cores' docstrings follow the project's plain style ("name: what it is",
    indented continuation lines); docutils reads those as broken block quotes.
    A docstring that does not parse cleanly keeps its first paragraph as text
    and shows the rest verbatim.
    """
    import io

    import docutils.core
    import docutils.utils
    text = '\n'.join(lines)
    try:
        docutils.core.publish_doctree(text, settings_overrides={
            'halt_level': docutils.utils.Reporter.WARNING_LEVEL, 'report_level': 5, 'warning_stream': io.StringIO()})
        return
    except docutils.utils.SystemMessage:
        pass
    except Exception:       # a Sphinx role needs the build environment: the text is reStructuredText
        return
    head_end = lines.index('') if '' in lines else len(lines)
    rest = lines[head_end:]
    lines[:] = lines[:head_end] + ['', '::', ''] + ['    ' + line for line in rest] + ['']


def setup(app):
    app.connect('autodoc-process-docstring', _plain_docstrings)
