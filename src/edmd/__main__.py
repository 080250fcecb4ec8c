"""``python -m edmd`` is the ``edmd`` command."""

from .cli import app

app()
