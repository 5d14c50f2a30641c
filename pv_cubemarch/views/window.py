"""The live view in a desktop window (pywebview): a process of its own, started by ``serve``.

``python -m pv_cubemarch.views.window URL`` opens the page (its URL carries the server's
secret) and returns when the window is closed; ``serve`` then stops the server.
"""

from __future__ import annotations

import sys


def main(url: str) -> None:
    """Open ``url`` in a pywebview window until it is closed."""
    import webview

    webview.create_window("pv_cubemarch", url)
    webview.start()


if __name__ == "__main__":
    main(sys.argv[1])
