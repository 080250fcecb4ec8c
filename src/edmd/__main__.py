"""``python -m edmd`` is the ``edmd`` command."""

from .app.cli import app

app()
