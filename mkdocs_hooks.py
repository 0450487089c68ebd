"""mkdocs hooks (mkdocs.yml ``hooks:``): the docstrings' Sphinx roles as plain code.

The docstrings cross-reference with Sphinx roles (``:class:`Controller```,
``:func:`~mpc.robots.preset```), which Markdown renders as the role's text before a code
span. This drops the role and, for a ``~`` target, keeps the last dotted name, as Sphinx
shows it.
"""

from __future__ import annotations

import re
from typing import Any

ROLE = re.compile(r":(?:py:)?(?:class|mod|func|meth|attr|data|exc|obj|const|term):"
                  r"<code>(~?)([^<]*)</code>")


def plain_roles(html: str) -> str:
    """``html`` with every ``:role:<code>target</code>`` as ``<code>target</code>``."""
    def code(match: re.Match[str]) -> str:
        tilde, target = match.groups()
        return f"<code>{target.rsplit('.', 1)[-1] if tilde else target}</code>"

    return ROLE.sub(code, html)


def on_page_content(html: str, **kwargs: Any) -> str:
    """mkdocs event: each page's HTML after Markdown."""
    return plain_roles(html)
