"""``unseeable view ESTIMATE.json``: an estimate as an interactive 3-D page."""

from __future__ import annotations

from unseeable.cli.camera import view_app
from unseeable.report.command import view_command

__all__ = ["view_command"]

view_app.command("show")(view_command)
