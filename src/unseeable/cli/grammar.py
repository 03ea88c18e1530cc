"""Commands about the grammar itself: ``unseeable grammar count``."""

from __future__ import annotations

import typer

from unseeable.cli import app

__all__ = ["grammar_app", "count_command"]

grammar_app = typer.Typer(name="grammar", help="The grammar of Lincoln Log assemblies.",
                          no_args_is_help=True)
app.add_typer(grammar_app, name="grammar")


@grammar_app.command("count")
def count_command(
    extent: str = typer.Option(..., "--extent", help="Grid size I,J,K (layers are J)."),
) -> None:
    """Print the exact number of valid structures of an extent (alone on the last line)."""
    from unseeable.domain import Extent
    from unseeable.grammar import count_valid

    grid = Extent.parse(extent, field="--extent")
    total = count_valid(grid)
    typer.echo(f"valid structures of a {grid} grid:")
    typer.echo(str(total))
