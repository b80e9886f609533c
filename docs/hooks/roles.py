"""mkdocs hook: Sphinx's inline roles in docstrings (``:class:`Module```) shown as the code they name.

The docstrings are written for Python's help() and Sphinx-style readers; mkdocstrings renders them as
Markdown, where the role's prefix would show as text before the code span."""
from __future__ import annotations

import re

_ROLE = re.compile(r":(?:class|func|meth|mod|attr|data|exc|obj):(?=<code>)")


def on_page_content(html: str, **_kwargs) -> str:
    """The page's HTML with each role prefix in front of a code span removed."""
    return _ROLE.sub("", html)
