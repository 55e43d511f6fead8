"""`elastyle view`: a local web viewer (Python's http.server on 127.0.0.1, one self-contained page).

Needs no extra packages: the page draws on a <canvas> with inline JavaScript and fetches nothing from the
internet. Core modules never import this package.
"""

from elastyle.viewer.app import build_payload, make_server, read_explain

__all__ = ["build_payload", "make_server", "read_explain"]
